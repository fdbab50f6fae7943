/* Temporary folders of the fuzz harness: removed with everything in them, so neither a
 * libFuzzer run nor a replay leaves anything in $TMPDIR (they once left one rt_fuzz.*
 * folder per replayed input). */
#ifndef RT_FUZZ_TMP_H
#define RT_FUZZ_TMP_H

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Removes path and, when it is a folder, everything below it (symbolic links are
 * removed, never followed). Best effort: what cannot be removed stays. */
static inline void fuzz_rmtree(const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0)
        return;
    if (S_ISDIR(st.st_mode)) {
        DIR *d = opendir(path);
        struct dirent *e;
        while (d && (e = readdir(d)) != NULL) {
            if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
                continue;
            char sub[4096];
            if ((size_t)snprintf(sub, sizeof sub, "%s/%s", path, e->d_name) < sizeof sub)
                fuzz_rmtree(sub);
        }
        if (d)
            closedir(d);
        rmdir(path);
    } else {
        unlink(path);
    }
}

/* The process's folder name (empty until fuzz_tmp_dir made it). */
static inline char *fuzz_tmp_state(void)
{
    static char path[4000];
    return path;
}

static inline void fuzz_tmp_cleanup(void)
{
    char *path = fuzz_tmp_state();
    if (path[0]) {
        /* Out of the folder first: a target may work inside it. */
        if (chdir("/") == 0)
            fuzz_rmtree(path);
        path[0] = '\0';
    }
}

/* This process's temporary folder, $TMPDIR/rt_fuzz.XXXXXX (or under /tmp), made on the
 * first call and removed with its contents when the process exits (libFuzzer's end of
 * run, a replayed input). A process killed by a signal cannot remove it: its runner
 * gives it a TMPDIR of its own and removes that (run.sh: build-fuzz/tmp/NAME; replay:
 * an rt_replay.* folder). NULL when it cannot be made. */
static inline const char *fuzz_tmp_dir(void)
{
    char *path = fuzz_tmp_state();
    if (path[0])
        return path;
    const char *base = getenv("TMPDIR");
    snprintf(path, 4000, "%s/rt_fuzz.XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(path)) {
        path[0] = '\0';
        return NULL;
    }
    atexit(fuzz_tmp_cleanup);
    return path;
}

#endif
