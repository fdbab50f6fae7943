# Dynamic checks beyond `make asan` (docs/testing.md):
#   make valgrind   the optimised build's binary under valgrind (memcheck, every leak kind
#                   an error, still-reachable blocks included) on a subset of scenes and
#                   options that fits CI, and the parser's unit tests
#   make tsan       the threaded code under ThreadSanitizer (build-tsan/): the set-up
#                   helpers, grid binning, the property test (packets), renders through
#                   the binary on 2 threads, and the preview's background render
# Both stop at the first error (exit status non-zero).

.PHONY: valgrind tsan

valgrind:
	$(Q)$(MAKE) --no-print-directory all tests
	$(Q)command -v valgrind >/dev/null 2>&1 || { echo "make valgrind: valgrind not found (apt-get install valgrind)"; exit 1; }
	$(Q)RT_BIN=$(abspath $(BIN)) RT_TESTS=$(abspath $(BUILD)/tests) bash tests/valgrind.sh

tsan:
	$(Q)$(MAKE) --no-print-directory BUILD=build-tsan OPT=-O1 SAN_FLAGS='-fsanitize=thread' all tests
	$(Q)RT_BIN=$(abspath build-tsan/raytracer) RT_TESTS=$(abspath build-tsan/tests) \
	    RT_TOOLS=$(abspath build-tsan/tools) bash tests/tsan.sh
