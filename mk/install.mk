# `make install` and `make uninstall` (README.txt: Installing). PREFIX (default
# /usr/local) and DESTDIR (staging root for packagers and tests) as in the GNU coding
# standards. Installs ./raytracer (and ./raytracer-mpi when `make mpi` built it), the
# manual page man/raytracer.1 and the bash completion completion/raytracer.bash (with
# raytracer-mpi, links to both under its name: "man raytracer-mpi" finds the page).
PREFIX  ?= /usr/local
DESTDIR ?=
BINDIR  ?= $(PREFIX)/bin
MANDIR  ?= $(PREFIX)/share/man
BASHCOMPDIR ?= $(PREFIX)/share/bash-completion/completions
INSTALL ?= install

.PHONY: install uninstall
# (the binaries by name: this file is read before the Makefile defines BIN)
RT_INSTALL_BIN = $(if $(filter build,$(BUILD)),raytracer,$(BUILD)/raytracer)
RT_INSTALL_MPI = $(wildcard $(if $(filter build,$(BUILD)),raytracer-mpi,$(BUILD)/raytracer-mpi))

install: all
	$(say) INSTALL $(DESTDIR)$(PREFIX)
	$(Q)$(INSTALL) -d '$(DESTDIR)$(BINDIR)' '$(DESTDIR)$(MANDIR)/man1' '$(DESTDIR)$(BASHCOMPDIR)'
	$(Q)$(INSTALL) -m 755 $(RT_INSTALL_BIN) $(RT_INSTALL_MPI) '$(DESTDIR)$(BINDIR)/'
	$(Q)$(INSTALL) -m 644 man/raytracer.1 '$(DESTDIR)$(MANDIR)/man1/raytracer.1'
	$(Q)$(INSTALL) -m 644 completion/raytracer.bash '$(DESTDIR)$(BASHCOMPDIR)/raytracer'
	$(Q)if [ -n '$(RT_INSTALL_MPI)' ]; then \
	    ln -sf raytracer '$(DESTDIR)$(BASHCOMPDIR)/raytracer-mpi' && \
	    ln -sf raytracer.1 '$(DESTDIR)$(MANDIR)/man1/raytracer-mpi.1'; fi

# Removes exactly what install puts there. The folders stay, even empty: install makes
# none of the project's own (no share/raytracer, no share/doc/raytracer), only the
# shared BINDIR, MANDIR/man1 and BASHCOMPDIR (and their parents) when they are missing,
# and another program's install may rely on those being there.
uninstall:
	$(say) UNINST $(DESTDIR)$(PREFIX)
	$(Q)rm -f '$(DESTDIR)$(BINDIR)/raytracer' '$(DESTDIR)$(BINDIR)/raytracer-mpi' \
	    '$(DESTDIR)$(MANDIR)/man1/raytracer.1' '$(DESTDIR)$(MANDIR)/man1/raytracer-mpi.1' \
	    '$(DESTDIR)$(BASHCOMPDIR)/raytracer' '$(DESTDIR)$(BASHCOMPDIR)/raytracer-mpi'
