# Benchmarks, the demo's models and the optional Embree reference tracer (bench/, docs/benchmarks.md).
#   make models   regenerate the committed OBJ models in models/ with build/tools/modelgen
#   make bench    the full benchmark: course suite, throughput, set-up, Embree pairing;
#                 BENCH_RUNS=N (median of N, default 3), BENCH_QUICK=1 (a short run),
#                 BENCH_BRUTE=0 (skip the brute-force column of the course suite),
#                 BENCH_ONLY=letters (only those sections of the report, e.g. e or g)
# The Embree reference (bench/embree_ref.c) is built only when Debian's libembree-dev is
# installed; nothing else in the build needs it.

# This fragment is read before the main Makefile defines `all`: keep `all` the default.
.DEFAULT_GOAL := all

EMBREE_HEADER := /usr/include/embree3/rtcore.h
HAVE_EMBREE   := $(if $(wildcard $(EMBREE_HEADER)),1,0)
EMBREE_REF    := $(BUILD)/bench/embree_ref
GRID_REF      := $(BUILD)/bench/grid_ref
BENCH_RUNS    ?= 3
BENCH_QUICK   ?= 0
BENCH_BRUTE   ?= 1
BENCH_ONLY    ?= abcegh

.PHONY: models bench embree_ref grid_ref

# The committed models, made by the project's own generator (tools/modelgen.c).
models: $(BUILD)/tools/modelgen
	$(BUILD)/tools/modelgen -o models/icosahedron.obj icosphere 0
	$(BUILD)/tools/modelgen -o models/icosphere.obj icosphere 3
	$(BUILD)/tools/modelgen -o models/torus.obj torus 1 0.35 48 24
	$(BUILD)/tools/modelgen -o models/vase.obj vase 48 40
	$(BUILD)/tools/modelgen -o models/ground.obj ground 24 8 0.15

# Recipes expand late, so $(BIN)/$(LIB) (defined after this fragment is included) are
# safe here but not in prerequisite lists: build through a sub-make instead.
bench:
	$(Q)$(MAKE) --no-print-directory all grid_ref
	$(Q)if [ "$(HAVE_EMBREE)" = 1 ]; then $(MAKE) --no-print-directory embree_ref; \
	    else echo "bench: libembree-dev not installed: no Embree pairing (apt-get install libembree-dev)"; fi
	$(Q)BENCH_RUNS=$(BENCH_RUNS) BENCH_QUICK=$(BENCH_QUICK) BENCH_BRUTE=$(BENCH_BRUTE) BENCH_ONLY=$(BENCH_ONLY) \
	    RT_BIN=$(abspath $(BIN)) RT_TOOLS=$(abspath $(BUILD)/tools) GRID_REF=$(abspath $(GRID_REF)) \
	    EMBREE_REF=$(if $(filter 1,$(HAVE_EMBREE)),$(abspath $(EMBREE_REF))) \
	    bash bench/run.sh

embree_ref: $(BUILD)/bench/embree_ref

$(BUILD)/bench/embree_ref: bench/embree_ref.c bench/bench_util.h $(BUILD)/librt.a
	@mkdir -p $(dir $@)
	$(say) CC $<
	$(Q)$(CC) $(ALL_CFLAGS) -O3 -o $@ $< $(BUILD)/librt.a $(LDLIBS_ALL) -lembree3

# Our grid traced like embree_ref traces Embree (traversal only): the like-for-like column.
grid_ref: $(BUILD)/bench/grid_ref

$(BUILD)/bench/grid_ref: bench/grid_ref.c bench/bench_util.h $(BUILD)/librt.a
	@mkdir -p $(dir $@)
	$(say) CC $<
	$(Q)$(CC) $(ALL_CFLAGS) -o $@ $< $(BUILD)/librt.a $(LDLIBS_ALL)
