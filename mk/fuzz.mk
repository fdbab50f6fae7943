# Fuzz targets (tests/fuzz/, docs/tests-and-ci.md).
#   make fuzz     build every tests/fuzz/fuzz_NAME.c with clang's libFuzzer and
#                 ASan+UBSan into build-fuzz/ and run each for FUZZ_SECONDS (default 30);
#                 fails on any crash, leak, timeout (> 2 s per input) or out-of-memory
#                 (> 2 GiB). FUZZ_JOBS=2 runs two at a time; FUZZ_TARGETS="scene obj"
#                 picks some; failing inputs land in build-fuzz/artifacts/NAME/.
# The same sources are built with the ordinary compiler against tests/fuzz/replay.c into
# $(BUILD)/tests/fuzz/replay_NAME, which `make test` runs on tests/fuzz/regress/NAME/:
# every input that ever failed stays a regression test without clang.

FUZZ_NAMES   := $(sort $(patsubst tests/fuzz/fuzz_%.c,%,$(wildcard tests/fuzz/fuzz_*.c)))
FUZZ_CC      ?= clang-14
FUZZ_SECONDS ?= 30
FUZZ_JOBS    ?= 1
FUZZ_TARGETS ?= $(FUZZ_NAMES)
FUZZ_BUILD   := build-fuzz
FUZZ_SAN     := -fsanitize=address,undefined -fno-omit-frame-pointer \
                -fno-sanitize-recover=undefined

EXTRA_TEST_BINS += $(FUZZ_NAMES:%=$(BUILD)/tests/fuzz/replay_%)

.PHONY: fuzz fuzz-bins

$(BUILD)/tests/fuzz/replay_%: $(BUILD)/tests/fuzz/fuzz_%.o $(BUILD)/tests/fuzz/replay.o \
                              $(BUILD)/librt.a
	$(say) LINK $@
	$(Q)$(CC) -o $@ $^ $(LDLIBS_ALL)

# Inside the sub-make below (BUILD=build-fuzz, CC=clang): the library instrumented for
# coverage (fuzzer-no-link), each target linked with libFuzzer's main.
fuzz-bins: $(FUZZ_TARGETS:%=$(BUILD)/fuzz/fuzz_%)

$(BUILD)/fuzz/fuzz_%: $(BUILD)/tests/fuzz/fuzz_%.o $(BUILD)/librt.a
	@mkdir -p $(dir $@)
	$(say) LINK $@
	$(Q)$(CC) -fsanitize=fuzzer -o $@ $^ $(LDLIBS_ALL)

fuzz:
	$(Q)command -v $(FUZZ_CC) >/dev/null 2>&1 || { echo "make fuzz: $(FUZZ_CC) not found (apt-get install clang-14 libclang-rt-14-dev)"; exit 1; }
	$(Q)$(MAKE) --no-print-directory BUILD=$(FUZZ_BUILD) CC=$(FUZZ_CC) OPT=-O1 \
	    SAN_FLAGS='-fsanitize=fuzzer-no-link $(FUZZ_SAN)' FUZZ_TARGETS='$(FUZZ_TARGETS)' fuzz-bins
	$(Q)bash tests/fuzz/run.sh $(FUZZ_BUILD) $(FUZZ_SECONDS) $(FUZZ_JOBS) $(FUZZ_TARGETS)

# The targets' objects are not named after their binaries: include their dependencies.
-include $(FUZZ_NAMES:%=$(BUILD)/tests/fuzz/fuzz_%.d) $(BUILD)/tests/fuzz/replay.d
