/* Fuzz target: the TGA decoder on raw bytes (and, when it accepts them, the encoder on
 * the decoded image: what we read we can write). */
#include "fuzz.h"
#include "fuzz_image.h"

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_codec("tga", data, size);
    return 0;
}
