# raytracer: plain GNU make, no configure step (docs/design.md).
#   make          build ./raytracer and the tools
#   make test     build and run every test (ends with "N passed, N failed")
#   make asan     the same suite under AddressSanitizer + UndefinedBehaviorSanitizer
#   make demo     render the showcase scene into demo/
#   make bench    benchmarks (bench/README)
#   make static   ./raytracer-static: linked statically, no preview (mk/static.mk)
#   make clean
# Options: V=1 (show commands), WERROR=1 (warnings are errors; CI), PREVIEW=0|1 (force
# the OpenGL preview off/on; default: on when pkg-config finds GL, GLUT and OSMesa),
# PNG=0|1 (likewise for libpng), CC=clang (default gcc).

# make predefines CC as cc, so `CC ?= gcc` would never apply: replace only make's own
# default and keep a CC given on the command line or in the environment.
ifeq ($(origin CC),default)
  CC := gcc
endif
BUILD   ?= build
OPT     ?= -O2
WARN    := -Wall -Wextra -Wshadow -Wstrict-prototypes -Wmissing-prototypes \
           -Wdouble-promotion -Wformat=2
CFLAGS  ?= $(OPT) -g
ALL_CFLAGS = -std=c11 -D_DEFAULT_SOURCE $(CFLAGS) $(WARN) $(WERROR_FLAG) -Iinclude -MMD -MP \
           -pthread $(FEATURE_CFLAGS) $(SAN_FLAGS)
LDLIBS_ALL = -lm -pthread $(FEATURE_LIBS) $(SAN_FLAGS)

WERROR_FLAG :=
ifeq ($(WERROR),1)
  WERROR_FLAG := -Werror
endif
ifeq ($(SAN),1)
  SAN_FLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
endif

ifeq ($(V),1)
  Q :=
  say = @true
else
  Q := @
  say = @printf '  %-7s %s\n'
endif

FEATURE_CFLAGS :=
FEATURE_LIBS   :=
FEATURES       :=

# Optional features register themselves here (PNG, preview, bench): each fragment may
# add to FEATURE_CFLAGS, FEATURE_LIBS, FEATURES, EXTRA_SRCS and define its own targets.
EXTRA_SRCS :=
EXTRA_TEST_BINS :=
include $(sort $(wildcard mk/*.mk))

LIB_SRCS := $(sort $(wildcard src/core/*.c src/scene/*.c src/geom/*.c src/accel/*.c \
                              src/shade/*.c src/render/*.c src/io/*.c)) $(EXTRA_SRCS)
LIB_OBJS := $(LIB_SRCS:%.c=$(BUILD)/%.o)
MAIN_OBJ := $(BUILD)/src/main.o
LIB      := $(BUILD)/librt.a

TEST_SRCS := $(sort $(wildcard tests/unit/test_*.c tests/e2e/test_*.c))
TEST_BINS := $(patsubst tests/%.c,$(BUILD)/tests/%,$(TEST_SRCS)) $(EXTRA_TEST_BINS)
HARNESS_OBJ := $(BUILD)/tests/harness.o

TOOL_SRCS := $(sort $(wildcard tools/*.c))

# The compiler and flags of the last build, kept in $(BUILD)/flags: every object and link
# depends on that file, and it is rewritten only when they change, so `make PNG=0` or
# `make CC=clang` after a plain `make` rebuilds instead of mixing objects. -Werror is
# left out: it changes no object, and the landing routine alternates `make WERROR=1` and
# `make test` (a tree that built with warnings is rebuilt by `make clean`).
FLAGS_FILE := $(BUILD)/flags
FLAGS_NOW   = $(CC) $(filter-out -Werror,$(ALL_CFLAGS)) | $(LDLIBS_ALL)
ifeq ($(filter clean,$(MAKECMDGOALS)),)
  $(shell mkdir -p $(BUILD) && \
      if [ "$$(cat $(FLAGS_FILE) 2>/dev/null)" != '$(FLAGS_NOW)' ]; then \
          printf '%s\n' '$(FLAGS_NOW)' > $(FLAGS_FILE); fi)
endif
TOOL_BINS := $(patsubst tools/%.c,$(BUILD)/tools/%,$(TOOL_SRCS))

# The binary sits at the top of the tree so users run ./raytracer; ASan builds keep
# theirs inside their build folder.
ifeq ($(BUILD),build)
  BIN := raytracer
else
  BIN := $(BUILD)/raytracer
endif

.PHONY: all test asan demo clean tools tests
# Keep the objects of test and tool binaries (make would delete them as intermediates).
.SECONDARY:
all: $(BIN) tools

tools: $(TOOL_BINS)
tests: $(TEST_BINS)

# ./raytracer runs alone (src/dist/dist_local.c); mk/mpi.mk links the same main with
# src/dist/dist_mpi.c into ./raytracer-mpi.
DIST_LOCAL_OBJ := $(BUILD)/src/dist/dist_local.o
$(BIN): $(MAIN_OBJ) $(DIST_LOCAL_OBJ) $(LIB) $(FLAGS_FILE)
	$(say) LINK $@
	$(Q)$(CC) -o $@ $(filter-out $(FLAGS_FILE),$^) $(LDLIBS_ALL)

$(LIB): $(LIB_OBJS)
	$(say) AR $@
	$(Q)rm -f $@ && ar rcs $@ $^

$(BUILD)/%.o: %.c $(FLAGS_FILE)
	@mkdir -p $(dir $@)
	$(say) CC $<
	$(Q)$(CC) $(ALL_CFLAGS) -c -o $@ $<

# The packet kernel passes 32-byte vectors between its own static functions; GCC's note
# that such an ABI changed in GCC 4.6 concerns calls across objects, which never happen.
$(BUILD)/src/accel/%.o: ALL_CFLAGS += -Wno-psabi
# The AVX-512 packet kernel has FMA at hand: no fused a*b+c, every lane must round like
# the scalar code (clang fuses within a statement by default).
$(BUILD)/src/accel/grid_packet_avx512.o $(BUILD)/src/accel/grid_packet_avx512x8.o: ALL_CFLAGS += -ffp-contract=off
# The packet Phong kernels likewise (src/render/phong_packet_kernel.h): no fusing.
$(BUILD)/src/render/phong_packet_avx2.o $(BUILD)/src/render/phong_packet_avx512.o: ALL_CFLAGS += -Wno-psabi -ffp-contract=off
# The Gaussian's vector exp (filter.c) likewise: static 32-byte vectors, no fusing.
$(BUILD)/src/render/filter.o: ALL_CFLAGS += -Wno-psabi -ffp-contract=off
# The noise's AVX2 corners (perlin.c), marble's vector sine (marble.c) and the film's AVX2
# filter sums (film.c) likewise.
$(BUILD)/src/shade/perlin.o $(BUILD)/src/shade/marble.o $(BUILD)/src/render/film.o: ALL_CFLAGS += -Wno-psabi -ffp-contract=off
# The blend lanes' vectors (raytracer.c) likewise.
$(BUILD)/src/render/raytracer.o: ALL_CFLAGS += -Wno-psabi -ffp-contract=off
# The camera's AVX-512 sample rays (camera.c): no fusing.
$(BUILD)/src/shade/camera.o: ALL_CFLAGS += -ffp-contract=off

# The two-level grid's build and walk, and the set-up's binning, packing and OBJ parse at
# -O3 (bench/REPORT.txt, stad23): fewer instructions for the same IEEE operations in the
# same order (C11 mode contracts nothing: -ffp-contract=off is the ISO default, and no
# FMA target is set; no -ffast-math), so the same bits. Only in the default optimised
# build: a build that sets OPT (the sanitizer and fuzz builds' -O1, a debugging -O0 -g)
# keeps its own level, and gcc's ASan at -O3 took minutes on grid_cast.c alone.
ifeq ($(OPT),-O2)
O3_OBJS := $(addprefix $(BUILD)/src/,accel/twolevel.o accel/grid_cast.o accel/grid_bin.o \
             accel/grid_cells.o accel/grid_pack.o geom/triangle.o scene/obj_loader.o)
$(O3_OBJS): ALL_CFLAGS += -O3
endif

# Test sources include "harness.h" from tests/.
$(BUILD)/tests/%.o: ALL_CFLAGS += -Itests

$(BUILD)/tests/harness.o: tests/harness.c $(FLAGS_FILE)
	@mkdir -p $(dir $@)
	$(say) CC $<
	$(Q)$(CC) $(ALL_CFLAGS) -c -o $@ $<

$(BUILD)/tests/%: $(BUILD)/tests/%.o $(HARNESS_OBJ) $(LIB) $(FLAGS_FILE)
	$(say) LINK $@
	$(Q)$(CC) -o $@ $(filter-out $(FLAGS_FILE),$^) $(LDLIBS_ALL)

# The allocation-failure injector of tests/e2e/test_oom.c, preloaded into the binary
# under test: a shared library of its own, without the sanitizers (their runtime must
# be the first library a process loads; the test skips itself in those builds).
OOM_SHIM := $(BUILD)/tests/liboom_shim.so
$(OOM_SHIM): tests/support/oom_shim.c $(FLAGS_FILE)
	@mkdir -p $(dir $@)
	$(say) CC $@
	$(Q)$(CC) -O2 -fPIC -shared -Wall -Wextra $(WERROR_FLAG) -o $@ $< -ldl

$(BUILD)/tools/%: $(BUILD)/tools/%.o $(LIB) $(FLAGS_FILE)
	$(say) LINK $@
	$(Q)$(CC) -o $@ $(filter-out $(FLAGS_FILE),$^) $(LDLIBS_ALL)

# The test command of README.txt. RT_BIN/RT_IMGDIFF point the end-to-end tests at
# this build's binaries.
test: $(BIN) tools $(TEST_BINS) $(OOM_SHIM)
	$(Q)RT_BIN=$(abspath $(BIN)) RT_TOOLS=$(abspath $(BUILD)/tools) \
	    RT_OOM_SHIM=$(abspath $(OOM_SHIM)) \
	    RT_MPI_BIN=$(abspath $(MPI_BIN)) RT_STATIC_BIN=$(abspath raytracer-static) \
	    sh tests/run_tests.sh $(TEST_BINS)

asan:
	$(Q)$(MAKE) --no-print-directory BUILD=build-asan SAN=1 OPT=-O1 test

# The tools too: README's next steps after make demo use build/tools/imgdiff.
demo: all
	$(Q)sh scenes/demo.sh $(abspath $(BIN))

clean:
	rm -rf build build-asan build-clang build-fuzz build-static build-tsan raytracer \
	    raytracer-mpi raytracer-static demo

# Every dependency file of this build folder, whichever rule (or mk/ fragment) made the
# object: a header change must rebuild the fuzz replays and benchmark tools too.
-include $(wildcard $(BUILD)/*.d $(BUILD)/*/*.d $(BUILD)/*/*/*.d $(BUILD)/*/*/*/*.d)
