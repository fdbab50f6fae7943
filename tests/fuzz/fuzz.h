/* Shared by the fuzz targets (tests/fuzz/fuzz_*.c): the libFuzzer entry points. Each
 * target is built twice: with clang's libFuzzer and ASan+UBSan by `make fuzz`
 * (mk/fuzz.mk), and with the ordinary compiler against tests/fuzz/replay.c, which
 * replays the inputs of tests/fuzz/regress/<target>/ in `make test`. A target must not
 * keep state between inputs beyond what its initialisation makes. */
#ifndef RT_FUZZ_H
#define RT_FUZZ_H

#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);

#endif
