/* Fuzz target: the PNG decoder (libpng underneath) on raw bytes, and when it accepts
 * them the encoder on the decoded image. A build without libpng has no PNG decoder:
 * the target then runs nothing. */
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
    fuzz_codec("png", data, size);
    return 0;
}
