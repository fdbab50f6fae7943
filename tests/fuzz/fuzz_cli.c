/* Fuzz target: the command line. The input's bytes are split at NUL bytes into argv
 * (at most 64 words) and given to options_parse, the program's whole option handling
 * before any file is opened; a usage error goes to a sink. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "rt/options.h"

enum { MAX_WORDS = 64 };

static FILE *g_sink;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    g_sink = fopen("/dev/null", "w");
    if (!g_sink)
        abort();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* A private copy with a NUL after every word, so no word reaches past the input. */
    char *buf = malloc(size + 1);
    if (!buf)
        return 0;
    memcpy(buf, data, size);
    buf[size] = '\0';
    char *argv[MAX_WORDS + 2];
    int argc = 0;
    argv[argc++] = "raytracer";
    for (size_t i = 0; i <= size && argc <= MAX_WORDS;) {
        argv[argc++] = buf + i;
        i += strlen(buf + i) + 1;
    }
    argv[argc] = NULL;
    Options o;
    options_defaults(&o);
    if (options_parse(&o, argc, argv, g_sink) && o.help)
        options_usage(g_sink);
    free(buf);
    return 0;
}
