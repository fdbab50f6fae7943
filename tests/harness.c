/* Fork-per-test runner for the unit and end-to-end test binaries (tests/harness.h). */
#define _POSIX_C_SOURCE 200809L
#include "harness.h"

#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

int harness_failures;

enum { SKIP_STATUS = 77 };

void harness_fail(const char *file, int line, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "    %s:%d: ", file, line);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    harness_failures++;
}

void harness_skip(const char *reason)
{
    /* A skip never hides a failure: a test that already failed a check ends failed. */
    if (harness_failures) {
        printf("(then skipped: %s) ", reason);
        fflush(stdout);
        _exit(1);
    }
    printf("SKIP (%s)", reason);
    fflush(stdout);
    _exit(SKIP_STATUS);
}

const char *harness_bin(void)
{
    const char *b = getenv("RT_BIN");
    return b && *b ? b : "./raytracer";
}

const char *harness_root(void)
{
    const char *r = getenv("RT_ROOT");
    return r && *r ? r : ".";
}

const char *harness_course_dir(void)
{
    static char buf[4096];
    const char *c = getenv("RT_COURSE");
    struct stat st;
    if (!(c && *c)) {
        snprintf(buf, sizeof buf, "%s/../shared/course", harness_root());
        c = buf;
    }
    if (stat(c, &st) != 0 || !S_ISDIR(st.st_mode))
        return NULL;
    return c;
}

int harness_main(int argc, char **argv, const TestCase *tests, int count)
{
    int passed = 0, failed = 0, skipped = 0;
    const char *only = argc > 1 ? argv[1] : NULL; /* run the tests whose name contains it */
    /* The programs under test keep a stop signal ignored when they are started with it
     * ignored (nohup, a script's background job). The tests that send SIGINT, SIGTERM
     * or SIGHUP model a user at a terminal, so every test starts with the defaults,
     * however make test itself was started (a CI script's background job ignores
     * SIGINT). */
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    signal(SIGHUP, SIG_DFL);

    for (int i = 0; i < count; i++) {
        if (only && !strstr(tests[i].name, only))
            continue;
        printf("%-52s ", tests[i].name);
        fflush(stdout);
        fflush(stderr);
        pid_t pid = fork();
        if (pid < 0) {
            perror("fork");
            return 1;
        }
        if (pid == 0) {
            harness_failures = 0;
            tests[i].fn();
            fflush(stdout);
            _exit(harness_failures ? 1 : 0);
        }
        int status = 0;
        while (waitpid(pid, &status, 0) < 0) {
        }
        if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
            printf("ok\n");
            passed++;
        } else if (WIFEXITED(status) && WEXITSTATUS(status) == SKIP_STATUS) {
            printf("\n");
            skipped++;
        } else if (WIFSIGNALED(status)) {
            printf("FAIL (crashed: signal %d)\n", WTERMSIG(status));
            failed++;
        } else {
            printf("FAIL\n");
            failed++;
        }
        fflush(stdout);
    }
    if (skipped)
        printf("%d passed, %d failed, %d skipped\n", passed, failed, skipped);
    else
        printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
