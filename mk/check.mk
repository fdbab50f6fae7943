# Dynamic checks beyond `make asan` (docs/tests-and-ci.md):
#   make valgrind   the optimised build's binary under valgrind (memcheck, every leak kind
#                   an error, still-reachable blocks included) on a subset of scenes and
#                   options that fits CI, and the parser's unit tests
#   make tsan       the threaded code under ThreadSanitizer (build-tsan/): the set-up
#                   helpers, grid binning, the property test (packets), renders through
#                   the binary on 2 threads, and the preview's background render
#   make diffcheck  the byte rule on random scenes (tools/diffcheck.c): N scenes (default
#                   200) from SEED (default 1), each rendered brute force, with -grid auto,
#                   -grid nx ny nz, -accel twolevel, packets or not, 1-3 threads, in parts
#                   merged, and compared byte for byte; DIFFCHECK_FLAGS adds options
#                   (-quick, -keep, -v, -dir DIR, -sets K, -stop, -no_reduce)
# Each stops at the first error (exit status non-zero); diffcheck reports every
# difference and keeps the scenes that differ.

.PHONY: valgrind tsan diffcheck

valgrind:
	$(Q)$(MAKE) --no-print-directory all tests
	$(Q)command -v valgrind >/dev/null 2>&1 || { echo "make valgrind: valgrind not found (apt-get install valgrind)"; exit 1; }
	$(Q)RT_BIN=$(abspath $(BIN)) RT_TESTS=$(abspath $(BUILD)/tests) bash tests/valgrind.sh

tsan:
	$(Q)$(MAKE) --no-print-directory BUILD=build-tsan OPT=-O1 SAN_FLAGS='-fsanitize=thread' all tests
	$(Q)RT_BIN=$(abspath build-tsan/raytracer) RT_TESTS=$(abspath build-tsan/tests) \
	    RT_TOOLS=$(abspath build-tsan/tools) bash tests/tsan.sh

# Recipes expand late, so $(BIN) (defined after this fragment is read) is safe here.
N ?= 200
SEED ?= 1
diffcheck:
	$(Q)$(MAKE) --no-print-directory all
	$(Q)$(BUILD)/tools/diffcheck -bin $(abspath $(BIN)) -n $(N) -seed $(SEED) $(DIFFCHECK_FLAGS)
