/* Fuzz target: the PPM (P6) decoder on raw bytes (and, when it accepts them, the encoder on
 * the decoded image: what we read we can write). */
#include <stdlib.h>

#include "fuzz.h"
#include "rt/image.h"

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Image img;
    char err[256];
    if (ppm_decode(data, size, &img, err, sizeof err)) {
        uint8_t *out = NULL;
        size_t len = 0;
        if (ppm_encode(&img, &out, &len))
            free(out);
        image_free(&img);
    }
    return 0;
}
