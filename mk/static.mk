# `make static`: ./raytracer-static, the same program linked statically (-static-pie:
# libc, libm, libpng and zlib inside the binary) and without the OpenGL preview (it
# opens its libraries at run time, which a static binary cannot rely on). A process
# of it starts without the dynamic loader: on the machine we measure, 3-4 ms less CPU
# and ~55 fewer page faults per process, which is what a split render of many small
# parts pays once per part (README.txt section 8, docs/distributed.md). Needs the
# static libraries (Debian: libc6-dev, libpng-dev, zlib1g-dev). Built by a make of its
# own in build-static with STATIC=1 PREVIEW=0, so its objects never mix with these.
STATIC ?=
ifeq ($(STATIC),1)
  FEATURE_LIBS += -static-pie
endif
STATIC_BIN := raytracer-static

.PHONY: static FORCE
static: $(STATIC_BIN)

# The make below knows the dependencies; the copy happens only when the binary
# changed, so the identity a -cache file records (rt/setup_cache.h) stays the same.
$(STATIC_BIN): FORCE
	$(Q)$(MAKE) --no-print-directory BUILD=build-static STATIC=1 PREVIEW=0 build-static/raytracer
	$(Q)cmp -s build-static/raytracer $@ || cp build-static/raytracer $@

# Once built, `make test` keeps it up to date and tests it (tests/e2e/test_cache.c).
# Only the default build does: `make asan` or a clang build (BUILD=build-clang) would
# otherwise pass their compiler and sanitizer settings down and rebuild it with them
# (a static binary cannot carry AddressSanitizer); they test the one already built.
ifeq ($(BUILD),build)
test: $(if $(wildcard $(STATIC_BIN)),$(STATIC_BIN))
endif
