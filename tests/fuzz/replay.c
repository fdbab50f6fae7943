/* Replays fuzz inputs through one target without libFuzzer: every file named on the
 * command line, or every file in the folders named there, each in its own process (a
 * crash or a hang fails that input only). Ends with "N passed, N failed" like the other
 * test binaries. Without arguments (`make test`): tests/fuzz/regress/<target>/ (every
 * input that once failed) and tests/fuzz/seeds/<target>/ (the committed seeds). */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fuzz.h"
#include "fuzz_tmp.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#define LEAKS_FOUND() (__lsan_do_recoverable_leak_check() != 0)
#else
#define LEAKS_FOUND() 0
#endif

/* Generous: the fuzzers' own limit is 2 s per input, sanitizer builds are slower. */
enum { REPLAY_TIMEOUT_S = 60 };

static int g_passed, g_failed;

static int run_one(const char *path, int argc, char **argv)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "replay: cannot open %s: %s\n", path, strerror(errno));
        return 1;
    }
    size_t cap = 1 << 16, len = 0;
    uint8_t *buf = malloc(cap);
    size_t n;
    while (buf && (n = fread(buf + len, 1, cap - len, f)) > 0) {
        len += n;
        if (len == cap) {
            uint8_t *nb = realloc(buf, cap * 2);
            if (!nb) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = nb;
            cap *= 2;
        }
    }
    fclose(f);
    if (!buf)
        return 1;
    /* A copy of exactly len bytes, so a read past the end is caught by ASan. */
    uint8_t *exact = malloc(len ? len : 1);
    if (!exact) {
        free(buf);
        return 1;
    }
    memcpy(exact, buf, len);
    free(buf);
    LLVMFuzzerInitialize(&argc, &argv);
    LLVMFuzzerTestOneInput(exact, len);
    free(exact);
    return LEAKS_FOUND() ? 1 : 0;
}

static void replay(const char *path, int argc, char **argv)
{
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        alarm(REPLAY_TIMEOUT_S);
        /* exit, not _exit: the target's exit handlers remove its temporary folder. */
        exit(run_one(path, argc, argv));
    }
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    const char *name = strrchr(path, '/');
    name = name ? name + 1 : path;
    if (WIFEXITED(st) && WEXITSTATUS(st) == 0) {
        printf("%-52s ok\n", name);
        g_passed++;
    } else {
        printf("%-52s FAIL (%s %d)\n", name, WIFEXITED(st) ? "exit" : "signal",
               WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st));
        g_failed++;
    }
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

int main(int argc, char **argv)
{
    /* Without arguments (make test): tests/fuzz/regress/<NAME> of the repository root
     * ($RT_ROOT or the working directory), NAME from this program's name replay_NAME. */
    char regress[4096], seeds[4096];
    char *dflt_argv[4] = {argv[0], regress, seeds, NULL};
    if (argc < 2) {
        const char *base = strrchr(argv[0], '/');
        base = base ? base + 1 : argv[0];
        if (strncmp(base, "replay_", 7) == 0)
            base += 7;
        const char *root = getenv("RT_ROOT");
        root = root && *root ? root : ".";
        snprintf(regress, sizeof regress, "%s/tests/fuzz/regress/%s", root, base);
        snprintf(seeds, sizeof seeds, "%s/tests/fuzz/seeds/%s", root, base);
        argc = 3;
        argv = dflt_argv;
    }
    /* The inputs' temporary folders go inside one of ours, removed at the end: an input
     * that crashes or hangs cannot remove its own. */
    const char *base = getenv("TMPDIR");
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s/rt_replay.XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(tmp) || setenv("TMPDIR", tmp, 1) != 0) {
        printf("replay: cannot make a temporary folder in %s: %s\n", base && *base ? base : "/tmp",
               strerror(errno));
        return 1;
    }
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) != 0) {
            if (argv == dflt_argv)
                continue; /* a target without regressions yet, or without seeds */
            printf("%s: %s\n", argv[i], strerror(errno));
            g_failed++;
            continue;
        }
        if (!S_ISDIR(st.st_mode)) {
            replay(argv[i], argc, argv);
            continue;
        }
        DIR *d = opendir(argv[i]);
        char **names = NULL;
        size_t count = 0;
        struct dirent *e;
        while (d && (e = readdir(d)) != NULL) {
            if (e->d_name[0] == '.')
                continue;
            char **nn = realloc(names, (count + 1) * sizeof *names);
            if (!nn)
                break;
            names = nn;
            size_t len = strlen(argv[i]) + strlen(e->d_name) + 2;
            names[count] = malloc(len);
            if (!names[count])
                break;
            snprintf(names[count], len, "%s/%s", argv[i], e->d_name);
            count++;
        }
        if (d)
            closedir(d);
        qsort(names, count, sizeof *names, cmp_str);
        for (size_t k = 0; k < count; k++) {
            replay(names[k], argc, argv);
            free(names[k]);
        }
        free(names);
    }
    fuzz_rmtree(tmp);
    if (g_passed + g_failed == 0) {
        printf("no input to replay\n");
        g_failed++;
    }
    printf("%d passed, %d failed\n", g_passed, g_failed);
    return g_failed ? 1 : 0;
}
