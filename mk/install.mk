# `make install` and `make uninstall` (README.txt: Installing). PREFIX (default
# /usr/local) and DESTDIR (staging root for packagers and tests) as in the GNU coding
# standards. Installs ./raytracer (and ./raytracer-mpi when `make mpi` built it), the
# manual page man/raytracer.1, the bash completion completion/raytracer.bash (with
# raytracer-mpi, links to both under its name: "man raytracer-mpi" finds the page) and
# README.txt, the user's guide the page's SEE ALSO names, into DOCDIR: an installed
# program has no source tree to point at. The page names DOCDIR's README as installed
# (its /usr/local/share/doc/raytracer, the default, is replaced by DOCDIR).
PREFIX  ?= /usr/local
DESTDIR ?=
BINDIR  ?= $(PREFIX)/bin
MANDIR  ?= $(PREFIX)/share/man
BASHCOMPDIR ?= $(PREFIX)/share/bash-completion/completions
DOCDIR  ?= $(PREFIX)/share/doc/raytracer
INSTALL ?= install

.PHONY: install uninstall
# (the binaries by name: this file is read before the Makefile defines BIN)
RT_INSTALL_BIN = $(if $(filter build,$(BUILD)),raytracer,$(BUILD)/raytracer)
RT_INSTALL_MPI = $(wildcard $(if $(filter build,$(BUILD)),raytracer-mpi,$(BUILD)/raytracer-mpi))

install: all
	$(say) INSTALL '$(DESTDIR)$(PREFIX)'
	$(Q)$(INSTALL) -d '$(DESTDIR)$(BINDIR)' '$(DESTDIR)$(MANDIR)/man1' '$(DESTDIR)$(BASHCOMPDIR)' \
	    '$(DESTDIR)$(DOCDIR)'
	$(Q)$(INSTALL) -m 755 $(RT_INSTALL_BIN) $(RT_INSTALL_MPI) '$(DESTDIR)$(BINDIR)/'
	$(Q)sed 's|/usr/local/share/doc/raytracer|$(subst &,\&,$(subst |,\|,$(DOCDIR)))|g' \
	    man/raytracer.1 > '$(DESTDIR)$(MANDIR)/man1/raytracer.1.tmp' && \
	    chmod 644 '$(DESTDIR)$(MANDIR)/man1/raytracer.1.tmp' && \
	    mv -f '$(DESTDIR)$(MANDIR)/man1/raytracer.1.tmp' '$(DESTDIR)$(MANDIR)/man1/raytracer.1'
	$(Q)$(INSTALL) -m 644 README.txt '$(DESTDIR)$(DOCDIR)/README.txt'
	$(Q)$(INSTALL) -m 644 completion/raytracer.bash '$(DESTDIR)$(BASHCOMPDIR)/raytracer'
	$(Q)if [ -n '$(RT_INSTALL_MPI)' ]; then \
	    ln -sf raytracer '$(DESTDIR)$(BASHCOMPDIR)/raytracer-mpi' && \
	    ln -sf raytracer.1 '$(DESTDIR)$(MANDIR)/man1/raytracer-mpi.1'; fi

# Removes exactly what install puts there. Of the folders, only the project's own DOCDIR
# goes (when nothing else was put in it): the shared BINDIR, MANDIR/man1, BASHCOMPDIR
# and DOCDIR's parent, which install makes when they are missing, stay, even empty:
# another program's install may rely on those being there.
uninstall:
	$(say) UNINST '$(DESTDIR)$(PREFIX)'
	$(Q)rm -f '$(DESTDIR)$(BINDIR)/raytracer' '$(DESTDIR)$(BINDIR)/raytracer-mpi' \
	    '$(DESTDIR)$(MANDIR)/man1/raytracer.1' '$(DESTDIR)$(MANDIR)/man1/raytracer-mpi.1' \
	    '$(DESTDIR)$(BASHCOMPDIR)/raytracer' '$(DESTDIR)$(BASHCOMPDIR)/raytracer-mpi' \
	    '$(DESTDIR)$(DOCDIR)/README.txt'
	$(Q)if [ -d '$(DESTDIR)$(DOCDIR)' ]; then rmdir '$(DESTDIR)$(DOCDIR)' 2>/dev/null || :; fi
