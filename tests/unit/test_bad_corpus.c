/* The bad-input corpus (tests/bad/NAME.txt + NAME.expect: exit status, then the message
 * with its location). Every file is checked in-process (scene_load) and through the
 * binary (exit status, message on stderr, no output file); each in its own process, so
 * one crash or hang names its file and the others still run. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "../harness.h"
#include "rt/scene.h"

/* Under ASan, LeakSanitizer checks each child explicitly: the harness ends children with
 * _exit(), which skips the automatic check at exit. */
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#define LEAKS_FOUND() (__lsan_do_recoverable_leak_check() != 0)
#else
#define LEAKS_FOUND() false
#endif

enum { MAX_FILES = 1024, TIMEOUT_S = 30 };

typedef struct Entry {
    char path[1400];    /* <root>/tests/bad/NAME.txt */
    char name[256];
    int status;         /* expected exit status */
    char msg[1024];     /* expected message substring */
} Entry;

static Entry g_entries[MAX_FILES];
static int g_count;

static int cmp_entry(const void *a, const void *b)
{
    return strcmp(((const Entry *)a)->name, ((const Entry *)b)->name);
}

/* Reads the corpus listing; reports a failure for any .txt without a valid .expect. */
static void load_corpus(void)
{
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/tests/bad", harness_root());
    DIR *d = opendir(dir);
    CHECK_MSG(d != NULL, "cannot open %s (run from the repository root or set RT_ROOT)", dir);
    if (!d)
        return;
    struct dirent *e;
    g_count = 0;
    while ((e = readdir(d)) != NULL && g_count < MAX_FILES) {
        size_t n = strlen(e->d_name);
        if (n < 5 || strcmp(e->d_name + n - 4, ".txt") != 0 || n >= sizeof g_entries[0].name)
            continue;
        Entry *en = &g_entries[g_count];
        snprintf(en->name, sizeof en->name, "%s", e->d_name);
        snprintf(en->path, sizeof en->path, "%s/%s", dir, e->d_name);
        char exp[1300];
        snprintf(exp, sizeof exp, "%s/%.*s.expect", dir, (int)(n - 4), e->d_name);
        FILE *f = fopen(exp, "r");
        CHECK_MSG(f != NULL, "%s: no .expect file", en->name);
        if (!f)
            continue;
        char line[1100];
        bool ok = fgets(line, sizeof line, f) != NULL;
        en->status = ok ? atoi(line) : -1;
        ok = ok && fgets(en->msg, sizeof en->msg, f) != NULL;
        fclose(f);
        en->msg[strcspn(en->msg, "\r\n")] = '\0';
        CHECK_MSG(ok && en->status > 0 && en->msg[0], "%s: malformed .expect", en->name);
        if (ok)
            g_count++;
    }
    closedir(d);
    qsort(g_entries, (size_t)g_count, sizeof g_entries[0], cmp_entry);
}

static void test_corpus_complete(void)
{
    load_corpus();
    CHECK_MSG(g_count >= 45, "only %d corpus files", g_count);
    for (int i = 0; i < g_count; i++) {
        /* The message names the file where the error is: this scene or an OBJ next to it. */
        CHECK_MSG(strncmp(g_entries[i].msg, "bad/", 4) == 0, "%s: message must start with bad/",
                  g_entries[i].name);
        CHECK_MSG(strstr(g_entries[i].msg, ": error: ") != NULL, "%s: no ': error: '",
                  g_entries[i].name);
    }
}

/* Waits for pid at most TIMEOUT_S seconds; kills it on a hang. */
static bool wait_bounded(pid_t pid, int *status)
{
    struct timespec nap = {0, 5 * 1000 * 1000};
    for (int i = 0; i < TIMEOUT_S * 200; i++) {
        pid_t r = waitpid(pid, status, WNOHANG);
        if (r == pid)
            return true;
        if (r < 0 && errno != EINTR)
            return false;
        nanosleep(&nap, NULL);
    }
    kill(pid, SIGKILL);
    waitpid(pid, status, 0);
    return false;
}

static void test_corpus_in_process(void)
{
    load_corpus();
    CHECK(g_count > 0);
    for (int i = 0; i < g_count; i++) {
        const Entry *en = &g_entries[i];
        fflush(stdout);
        fflush(stderr);
        pid_t pid = fork();
        if (pid == 0) {
            Diag d;
            diag_init(&d, NULL);
            Scene *s = scene_load(en->path, &d);
            /* What the program asks of a parsed scene before it renders (a camera and
             * a Group) is part of reading it here. */
            if (s && !scene_check_renderable(s, &d)) {
                scene_free(s);
                s = NULL;
            }
            int bad = 0;
            if (s) {
                fprintf(stderr, "    %s: parsed, expected \"%s\"\n", en->name, en->msg);
                bad = 1;
            } else if (!strstr(d.last, en->msg)) {
                fprintf(stderr, "    %s: got \"%s\"\n      expected \"%s\"\n", en->name, d.last,
                        en->msg);
                bad = 1;
            } else if (d.errors != 1) {
                fprintf(stderr, "    %s: %d errors reported, expected 1\n", en->name, d.errors);
                bad = 1;
            }
            scene_free(s);
            if (LEAKS_FOUND()) {
                fprintf(stderr, "    %s: memory leaked (report above)\n", en->name);
                bad = 1;
            }
            fflush(stderr);
            _exit(bad);
        }
        CHECK(pid > 0);
        int st = 0;
        bool done = pid > 0 && wait_bounded(pid, &st);
        CHECK_MSG(done, "%s: scene_load hung (killed after %d s)", en->name, TIMEOUT_S);
        if (done && WIFSIGNALED(st))
            CHECK_MSG(false, "%s: scene_load crashed (signal %d)", en->name, WTERMSIG(st));
        else if (done)
            CHECK_MSG(WEXITSTATUS(st) == 0, "%s: wrong result (above)", en->name);
    }
}

static bool dir_is_empty(const char *path)
{
    DIR *d = opendir(path);
    if (!d)
        return false;
    struct dirent *e;
    bool empty = true;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
            empty = false;
    closedir(d);
    return empty;
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *b = malloc(65536);
    size_t n = b ? fread(b, 1, 65535, f) : 0;
    if (b)
        b[n] = '\0';
    fclose(f);
    return b;
}

static void test_corpus_binary(void)
{
    load_corpus();
    const char *bin = harness_bin();
    CHECK_MSG(access(bin, X_OK) == 0, "binary %s not built (make builds it)", bin);
    if (access(bin, X_OK) != 0)
        return;
    char tmp[] = "/tmp/rt_badcorpus_XXXXXX";
    CHECK(mkdtemp(tmp) != NULL);
    char outdir[256], out[300], err[300];
    snprintf(outdir, sizeof outdir, "%s/out", tmp);
    snprintf(out, sizeof out, "%s/out.tga", outdir);
    snprintf(err, sizeof err, "%s/stderr.txt", tmp);
    CHECK(mkdir(outdir, 0700) == 0);
    for (int i = 0; i < g_count; i++) {
        const Entry *en = &g_entries[i];
        fflush(stdout);
        fflush(stderr);
        pid_t pid = fork();
        if (pid == 0) {
            int fe = open(err, O_WRONLY | O_CREAT | O_TRUNC, 0600);
            int fn = open("/dev/null", O_WRONLY);
            if (fe < 0 || fn < 0)
                _exit(126);
            dup2(fn, 1);
            dup2(fe, 2);
            execl(bin, bin, "-input", en->path, "-output", out, "-size", "10", "10", (char *)NULL);
            _exit(127);
        }
        CHECK(pid > 0);
        int st = 0;
        bool done = pid > 0 && wait_bounded(pid, &st);
        CHECK_MSG(done, "%s: the binary hung (killed after %d s)", en->name, TIMEOUT_S);
        if (!done)
            continue;
        if (WIFSIGNALED(st)) {
            CHECK_MSG(false, "%s: the binary crashed (signal %d)", en->name, WTERMSIG(st));
        } else {
            CHECK_MSG(WEXITSTATUS(st) == en->status, "%s: exit status %d, expected %d", en->name,
                      WEXITSTATUS(st), en->status);
        }
        char *text = slurp(err);
        CHECK_MSG(text && strstr(text, en->msg), "%s: stderr \"%s\"\n      expected \"%s\"",
                  en->name, text ? text : "(none)", en->msg);
        free(text);
        CHECK_MSG(dir_is_empty(outdir), "%s: the failed run left files in the output folder",
                  en->name);
        /* Start clean for the next file whatever happened. */
        unlink(out);
    }
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmp);
    CHECK(system(cmd) == 0);
}

static const TestCase tests[] = {
    {"corpus_complete", test_corpus_complete},
    {"corpus_in_process", test_corpus_in_process},
    {"corpus_binary", test_corpus_binary},
};

RT_TEST_MAIN(tests)
