/* End-to-end tests of the reliability defects: signals while the images are written,
 * several outputs all or nothing, the same file named twice, lost -stats output, and
 * the reproducers of tests/repro/. No test depends on timing: a run that must be caught
 * inside its write writes one image into a FIFO, which blocks it until the test has
 * read the first byte and sent the signal. */
#define _POSIX_C_SOURCE 200809L
#include <fcntl.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "../harness.h"
#include "e2e_util.h"
#include "rt/preview.h"

/* Runs the binary with args (NULL-terminated, without the program name). */
static int run(const char *const *args, E2eRun *r)
{
    if (!e2e_run_bin(harness_bin(), args, r))
        return -1;
    return r->status;
}

static const char *repro(char *buf, size_t size, const char *name)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/tests/repro", harness_root());
    return e2e_join(buf, size, dir, name);
}

static bool has_temp_file(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return false;
    bool found = false;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (e->d_name[0] == '.' && strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
            found = true;
    closedir(d);
    return found;
}

/* A signal while the images are being written: the colour image goes through its
 * temporary file (written first), the depth image into a FIFO the test reads. When
 * the test has the first byte of the depth image, the temporary colour file exists
 * and the run is blocked in the write (200x200 TGA > the pipe's buffer); then the
 * signal. Expected: exit 128 + signal, no image and no temporary file. Before the fix
 * SIGTERM/SIGHUP killed the run with the temporary file left behind, and SIGINT was
 * ignored until the image had been written (exit 0).
 * With `ignored` the run starts with the signal ignored (nohup's SIGHUP; the SIGINT a
 * shell gives a script's background jobs) and must keep it so: the same signal at the
 * same point, and the run goes on to write both images, exit 0. Before that fix it
 * caught it anyway: a nohup render ended at logout with no image (exit 129). */
static void signal_during_write_as(int sig, bool ignored)
{
    char dir[PATH_MAX], fifo[PATH_MAX], out[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, ignored ? "sigign" : "sigwrite") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "depth.tga");
    e2e_join(out, sizeof out, dir, "o.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    CHECK(mkfifo(fifo, 0600) == 0);
    const char *args[] = {harness_bin(), "-input", scene, "-output", out, "-depth", "0", "20",
                          fifo, "-size", "200", "200", NULL};
    if (ignored)
        signal(sig, SIG_IGN); /* inherited by the run, as from nohup or a shell */
    int errfd = -1;
    pid_t pid = e2e_spawn(args, &errfd);
    signal(sig, SIG_DFL);
    CHECK(pid > 0);
    /* Only a guard against a run that never ends (the defect): not a timing condition. */
    alarm(120);
    int fd = open(fifo, O_RDONLY);
    CHECK(fd >= 0);
    unsigned char buf[65536];
    CHECK(read(fd, buf, 1) == 1);
    if (!ignored)
        CHECK_MSG(has_temp_file(dir),
                  "no temporary colour image while the depth image is written");
    kill(pid, sig);
    long total = 1; /* the depth image's bytes read (ignored: to its end) */
    while (ignored) {
        ssize_t n = read(fd, buf, sizeof buf);
        if (n == 0 || (n < 0 && errno != EINTR))
            break;
        total += n > 0 ? n : 0;
    }
    int st = 0;
    while (waitpid(pid, &st, 0) < 0) {
    }
    close(fd);
    char err[4096] = "";
    if (errfd >= 0)
        e2e_read_close(errfd, err, sizeof err);
    const int want = ignored ? 0 : 128 + sig;
    CHECK_MSG(WIFEXITED(st) && WEXITSTATUS(st) == want, "signal %d%s: %s %d, expected exit %d: %s",
              sig, ignored ? " ignored" : "", WIFEXITED(st) ? "exit" : "killed by",
              WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), want, err);
    if (ignored) {
        CHECK_MSG(total == 18 + 200L * 200 * 3, "the depth image had %ld bytes", total);
        CHECK_MSG(e2e_exists(out), "the colour image was not written");
    } else {
        CHECK_CONTAINS(err, "interrupted");
        CHECK_MSG(!e2e_exists(out), "the colour image was written");
        CHECK_INT(e2e_count_entries(dir), 1); /* the FIFO */
    }
    CHECK_MSG(!has_temp_file(dir), "a temporary image was left behind");
    e2e_rmtree(dir);
}

static void signal_during_write(int sig) { signal_during_write_as(sig, false); }
static void signal_ignored_during_write(int sig) { signal_during_write_as(sig, true); }

static void test_sighup_ignored_like_nohup(void) { signal_ignored_during_write(SIGHUP); }
static void test_sigint_ignored_in_background(void) { signal_ignored_during_write(SIGINT); }

static void test_sigterm_during_write(void) { signal_during_write(SIGTERM); }
static void test_sighup_during_write(void) { signal_during_write(SIGHUP); }
static void test_sigint_during_write(void) { signal_during_write(SIGINT); }

/* A signal while one pixel's ray tree is being traced (tests/repro/deep_ray_tree.txt:
 * a camera inside three nested glass spheres, -bounces 60 -weight 0: the one tree of
 * the 1x1 image has some 10^15 rays, so without the fix the run never ends; render
 * threads polled the stop flag only between tiles). The signal is sent after 0.3 s
 * (whether the run is still parsing or already inside the pixel, it must stop); the
 * limit of 60 s is only a guard against the hang, not a timing condition. Expected:
 * exit 128 + signal, "interrupted" on stderr, no image, nothing left in the folder. */
static void signal_inside_pixel(int sig)
{
    char dir[PATH_MAX], out[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigpixel") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    repro(scene, sizeof scene, "deep_ray_tree.txt");
    const char *args[] = {harness_bin(), "-input", scene, "-output", out, "-size", "1", "1",
                          "-shade_back", "-bounces", "60", "-weight", "0", "-threads", "1",
                          NULL};
    int errfd = -1;
    pid_t pid = e2e_spawn(args, &errfd);
    CHECK(pid > 0);
    if (pid <= 0)
        return;
    struct timespec pause = {0, 300 * 1000 * 1000};
    nanosleep(&pause, NULL);
    kill(pid, sig);
    int st = 0;
    bool hung = !e2e_wait_or_kill(pid, 60, &st);
    char err[4096] = "";
    e2e_read_close(errfd, err, sizeof err);
    CHECK_MSG(!hung, "signal %d: the run did not stop within 60 s", sig);
    CHECK_MSG(!hung && WIFEXITED(st) && WEXITSTATUS(st) == 128 + sig,
              "signal %d: %s %d, expected exit %d", sig, WIFEXITED(st) ? "exit" : "killed by",
              WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), 128 + sig);
    if (!hung)
        CHECK_CONTAINS(err, "interrupted");
    CHECK_MSG(!e2e_exists(out), "an image was written");
    CHECK_INT(e2e_count_entries(dir), 0);
    e2e_rmtree(dir);
}

/* A signal while the render streams its image into a temporary file (the renderer
 * writes each finished band into it, rt/image.h image_encoding_stream; with film, an
 * antialiased render, each filtered strip: main.c stream_film): the test waits until
 * the temporary file exists (the one pixel of deep_ray_tree.txt then takes for ever;
 * 60 s is only a guard), then signals. Expected: exit 128 + signal, no image and no
 * temporary file left. (Before the antialiased render streamed, it made its file only
 * after the render: the film case then saw no temporary file.) */
static void signal_while_streaming_as(int sig, bool film)
{
    char dir[PATH_MAX], out[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigstream") != NULL);
    e2e_join(out, sizeof out, dir, "o.ppm");
    repro(scene, sizeof scene, "deep_ray_tree.txt");
    const char *args[] = {harness_bin(), "-input", scene, "-output", out, "-size", "1", "1",
                          "-shade_back", "-bounces", "60", "-weight", "0", "-threads", "2",
                          film ? "-jittered_samples" : NULL, "4", "-tent_filter", "1", NULL};
    int errfd = -1;
    pid_t pid = e2e_spawn(args, &errfd);
    CHECK(pid > 0);
    if (pid <= 0)
        return;
    bool seen = false;
    for (int i = 0; i < 6000 && !seen; i++) {
        seen = has_temp_file(dir);
        if (!seen) {
            struct timespec pause = {0, 10 * 1000 * 1000};
            nanosleep(&pause, NULL);
        }
    }
    CHECK_MSG(seen, "no temporary image while rendering");
    kill(pid, sig);
    int st = 0;
    bool hung = !e2e_wait_or_kill(pid, 60, &st);
    char err[4096] = "";
    e2e_read_close(errfd, err, sizeof err);
    CHECK_MSG(!hung && WIFEXITED(st) && WEXITSTATUS(st) == 128 + sig,
              "signal %d: %s %d, expected exit %d", sig, WIFEXITED(st) ? "exit" : "killed by",
              WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), 128 + sig);
    if (!hung)
        CHECK_CONTAINS(err, "interrupted");
    CHECK_MSG(!e2e_exists(out), "an image was written");
    CHECK_MSG(!has_temp_file(dir), "a temporary image was left behind");
    CHECK_INT(e2e_count_entries(dir), 0);
    e2e_rmtree(dir);
}

/* A signal before -gui_snapshot draws: the scene comes through a FIFO, so once the
 * test's open for writing returns, the run is reading it (its handlers are in place);
 * the signal comes before the scene does. Expected: exit 128 + signal, "interrupted",
 * no snapshot. Before the fix nothing in the snapshot looked at the stop flag: it drew
 * and wrote the picture and exited 0 (a window ignored Ctrl-C the same way,
 * test_gui_xvfb's window_stopped_by_signal). */
static void test_sigterm_before_snapshot(void)
{
    if (!preview_snapshot_built())
        harness_skip("built without OSMesa (apt-get install libosmesa6-dev, rebuild)");
    char dir[PATH_MAX], fifo[PATH_MAX], snap[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigsnap") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "scene.txt");
    e2e_join(snap, sizeof snap, dir, "snap.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    size_t len = 0;
    char *text = e2e_read_file(scene, &len);
    CHECK(text != NULL);
    CHECK(mkfifo(fifo, 0600) == 0);
    if (harness_failures)
        return;
    const char *args[] = {harness_bin(), "-input", fifo, "-gui_snapshot", snap, "-size", "8",
                          "8", NULL};
    int errfd = -1;
    pid_t pid = e2e_spawn(args, &errfd);
    CHECK(pid > 0);
    if (pid <= 0)
        return;
    alarm(120); /* a guard against a run that never ends, not a timing condition */
    int fd = open(fifo, O_WRONLY);
    CHECK(fd >= 0);
    kill(pid, SIGTERM);
    CHECK(fd >= 0 && write(fd, text, len) == (ssize_t)len);
    if (fd >= 0)
        close(fd);
    int st = 0;
    bool hung = !e2e_wait_or_kill(pid, 60, &st);
    char err[4096] = "";
    e2e_read_close(errfd, err, sizeof err);
    CHECK_MSG(!hung && WIFEXITED(st) && WEXITSTATUS(st) == 128 + SIGTERM,
              "%s %d, expected exit %d: %s", WIFEXITED(st) ? "exit" : "killed by",
              WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), 128 + SIGTERM, err);
    CHECK_CONTAINS(err, "interrupted; no image written");
    CHECK_MSG(!e2e_exists(snap), "the snapshot was written");
    CHECK_INT(e2e_count_entries(dir), 1); /* the FIFO */
    free(text);
    e2e_rmtree(dir);
}

/* A signal while -merge reads its parts: the first part is a FIFO, so once the test's
 * open for writing returns, the merge is reading it (its handlers are in place); the
 * signal comes before the part's bytes do. Expected: exit 128 + signal, "interrupted;
 * no image written", no output, nothing new in the folder. Before the fix -merge had
 * no handlers: SIGTERM killed it (a write cut that way left its temporary file behind)
 * and a SIGINT ignored by its parent was ignored too, and the image written (exit 0). */
static void signal_during_merge(int sig)
{
    char dir[PATH_MAX], fifo[PATH_MAX], part0[PATH_MAX], part1[PATH_MAX], out[PATH_MAX],
        scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigmerge") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "fifo.tga");
    e2e_join(part0, sizeof part0, dir, "p0.tga");
    e2e_join(part1, sizeof part1, dir, "p1.tga");
    e2e_join(out, sizeof out, dir, "whole.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    E2eRun r;
    const char *a0[] = {"-input", scene, "-size", "8", "8", "-tile", "0", "2", "-output",
                        part0, NULL};
    CHECK_INT(run(a0, &r), 0);
    e2e_run_free(&r);
    const char *a1[] = {"-input", scene, "-size", "8", "8", "-tile", "1", "2", "-output",
                        part1, NULL};
    CHECK_INT(run(a1, &r), 0);
    e2e_run_free(&r);
    size_t len = 0;
    char *bytes = e2e_read_file(part0, &len);
    CHECK(bytes != NULL);
    CHECK(mkfifo(fifo, 0600) == 0);
    if (harness_failures) {
        free(bytes);
        return;
    }
    const char *args[] = {harness_bin(), "-merge", out, fifo, part1, NULL};
    /* The part is read whole or not at all: a merge killed by the signal closes the
     * FIFO (the write meets EPIPE). */
    int st = 0;
    char err[4096] = "";
    bool ended = e2e_signal_while_reading(args, fifo, sig, bytes, len, &st, err, sizeof err);
    CHECK_MSG(ended && WIFEXITED(st) && WEXITSTATUS(st) == 128 + sig,
              "signal %d: %s %d, expected exit %d: %s", sig,
              WIFEXITED(st) ? "exit" : "killed by",
              WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), 128 + sig, err);
    CHECK_CONTAINS(err, "interrupted; no image written");
    CHECK_MSG(!e2e_exists(out), "the merged image was written");
    CHECK_INT(e2e_count_entries(dir), 3); /* the FIFO and the two parts */
    free(bytes);
    e2e_rmtree(dir);
}

static void test_sigterm_during_merge(void) { signal_during_merge(SIGTERM); }
static void test_sigint_during_merge(void) { signal_during_merge(SIGINT); }

/* A signal during the set-up, with -cache: the scene file is a FIFO (its OBJ file a
 * plain file next to it), so once the test's open for writing returns, the run is
 * reading the scene; the signal comes before the scene's bytes do. Expected: exit 128 +
 * signal, "interrupted; no image written", no image and no cache file: the run stops
 * after the phase the signal came in. Before the fix the set-up went on to its end
 * (grid build, the -cache file written: 2 s for a 1M-triangle mesh) and only the render
 * noticed the signal. (Not the OBJ file as the FIFO: with -cache it is opened twice,
 * its identity looked up first, and a test writing into the first open left the second
 * waiting for ever.) */
static void test_sigterm_during_setup(void)
{
    char dir[PATH_MAX], fifo[PATH_MAX], mesh[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigsetup") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "scene.txt");
    e2e_join(mesh, sizeof mesh, dir, "mesh.obj");
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(cache, sizeof cache, dir, "set.cache");
    CHECK(e2e_write_file(mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
    CHECK(mkfifo(fifo, 0600) == 0);
    if (harness_failures)
        return;
    const char *args[] = {harness_bin(), "-input", fifo, "-size", "8", "8", "-grid", "auto",
                          "-cache", cache, "-output", out, NULL};
    static const char scene[] =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n"
        "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
        "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mesh.obj } }\n";
    int st = 0;
    char err[4096] = "";
    bool ended = e2e_signal_while_reading(args, fifo, SIGTERM, scene, sizeof scene - 1, &st,
                                          err, sizeof err);
    CHECK_MSG(ended && WIFEXITED(st) && WEXITSTATUS(st) == 128 + SIGTERM,
              "%s %d, expected exit %d: %s", WIFEXITED(st) ? "exit" : "killed by",
              WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), 128 + SIGTERM, err);
    CHECK_CONTAINS(err, "interrupted; no image written");
    CHECK_MSG(!e2e_exists(out), "an image was written");
    CHECK_MSG(!e2e_exists(cache), "the set-up cache was written after the signal");
    CHECK_INT(e2e_count_entries(dir), 2); /* the FIFO and the OBJ file */
    e2e_rmtree(dir);
}

/* A signal during a big OBJ file's parse ends the parse itself, not just the run after
 * it: the reader looks at the stop flag every 64K lines (rt/par.h). The scene file is
 * the FIFO, as in sigterm_during_setup, so the signal is in before the OBJ file is
 * read; the generated mesh (70,004 lines, 560 KB: read in pieces on two threads) ends
 * with a face naming a vertex that does not exist. A parse that went on to its end
 * reported that line (exit 1: before the fix, the stop was looked at only after the
 * parse); a cut one never reaches it: exit 128 + signal, "interrupted; no image
 * written" and no error, no image and no -cache file. One thread (the serial reader)
 * and two (the pieces, then the serial reader). */
static void test_sigterm_during_obj_parse(void)
{
    enum { VERTS = 70000 };
    char dir[PATH_MAX], fifo[PATH_MAX], mesh[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigparse") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "scene.txt");
    e2e_join(mesh, sizeof mesh, dir, "mesh.obj");
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(cache, sizeof cache, dir, "set.cache");
    static const char vertex[] = "v 0 0 0\n";
    size_t vlen = sizeof vertex - 1;
    char tail[64];
    snprintf(tail, sizeof tail, "v 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 %d\n", VERTS + 3);
    char *obj = malloc(VERTS * vlen + sizeof tail);
    CHECK(obj != NULL);
    if (!obj)
        return;
    for (size_t i = 0; i < VERTS; i++)
        memcpy(obj + i * vlen, vertex, vlen);
    memcpy(obj + VERTS * vlen, tail, strlen(tail) + 1);
    CHECK(e2e_write_file(mesh, obj));
    free(obj);
    CHECK(mkfifo(fifo, 0600) == 0);
    if (harness_failures)
        return;
    static const char scene[] =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n"
        "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
        "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mesh.obj } }\n";
    static const char *const threads[] = {"1", "2"};
    for (int k = 0; k < 2; k++) {
        const char *args[] = {harness_bin(), "-input", fifo, "-size", "8", "8", "-grid",
                              "auto", "-threads", threads[k], "-cache", cache, "-output",
                              out, NULL};
        int st = 0;
        char err[4096] = "";
        bool ended = e2e_signal_while_reading(args, fifo, SIGTERM, scene, sizeof scene - 1,
                                              &st, err, sizeof err);
        CHECK_MSG(ended && WIFEXITED(st) && WEXITSTATUS(st) == 128 + SIGTERM,
                  "-threads %s: %s %d, expected exit %d: %s", threads[k],
                  WIFEXITED(st) ? "exit" : "killed by",
                  WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), 128 + SIGTERM, err);
        CHECK_CONTAINS(err, "interrupted; no image written");
        CHECK_MSG(!strstr(err, "error"), "-threads %s: the parse reached the end: %s",
                  threads[k], err);
        CHECK_MSG(!e2e_exists(out), "an image was written");
        CHECK_MSG(!e2e_exists(cache), "the set-up cache was written after the signal");
        CHECK_INT(e2e_count_entries(dir), 2); /* the FIFO and the OBJ file */
    }
    e2e_rmtree(dir);
}

/* A signal while an OBJ file is being read ends the read itself (rt/file.h: the read
 * looks at the stop flag before each step): the OBJ file is the FIFO this time (no
 * -cache, so it is opened once), the scene a plain file, and the signal is in while the
 * run waits for the OBJ's bytes. The bytes are an OBJ whose first line is an error (a
 * face before any vertex), which the reader reports at once, before its first look at
 * the flag: a read that went on to its end led to that error (exit 1, on 1f2bcd1); a
 * cut one to exit 128 + signal, "interrupted; no image written", no error, no image.
 * One thread and two. */
static void test_sigterm_during_obj_read(void)
{
    char dir[PATH_MAX], fifo[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigread") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "mesh.obj");
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    CHECK(e2e_write_file(
        scene, "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
               "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n"
               "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
               "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mesh.obj } }\n"));
    CHECK(mkfifo(fifo, 0600) == 0);
    if (harness_failures)
        return;
    static const char obj[] = "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
    static const char *const threads[] = {"1", "2"};
    for (int k = 0; k < 2; k++) {
        const char *args[] = {harness_bin(), "-input", scene, "-size", "8", "8", "-threads",
                              threads[k], "-output", out, NULL};
        int st = 0;
        char err[4096] = "";
        bool ended = e2e_signal_while_reading(args, fifo, SIGTERM, obj, sizeof obj - 1, &st,
                                              err, sizeof err);
        CHECK_MSG(ended && WIFEXITED(st) && WEXITSTATUS(st) == 128 + SIGTERM,
                  "-threads %s: %s %d, expected exit %d: %s", threads[k],
                  WIFEXITED(st) ? "exit" : "killed by",
                  WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st), 128 + SIGTERM, err);
        CHECK_CONTAINS(err, "interrupted; no image written");
        CHECK_MSG(!strstr(err, "error"), "-threads %s: the OBJ file was read to its end: %s",
                  threads[k], err);
        CHECK_MSG(!e2e_exists(out), "an image was written");
        CHECK_INT(e2e_count_entries(dir), 2); /* the FIFO and the scene */
    }
    e2e_rmtree(dir);
}

/* A run stopped by signal sig before writing (it ended, with status st and stderr
 * err): exit 128 + sig, the message, and no image at out. */
static void check_interrupted(bool ended, int st, int sig, const char *err, const char *out)
{
    CHECK_MSG(ended && WIFEXITED(st) && WEXITSTATUS(st) == 128 + sig,
              "status %#x, expected exit %d: %s", st, 128 + sig, err);
    CHECK_CONTAINS(err, "interrupted; no image written");
    CHECK_MSG(!e2e_exists(out), "an image was written");
}

/* A stop signal while the run waits for input that does not come: the scene is a FIFO
 * whose writer (this test) has sent part of the scene and keeps it open, as a terminal
 * waiting for "-input -" does or a slow pipe. Once the FIFO holds no unread bytes
 * (FIONREAD), the run has taken them and waits in its read for more; the signal must end
 * it there. Before the fix the read restarted after the handler (SA_RESTART) and the
 * flag was looked at only when more input or the end came: the run was still waiting
 * 20 s after the signal (Ctrl-C at a terminal did nothing until Ctrl-D). The writer
 * stays open until the run has ended or the guard has passed. SIGINT and SIGTERM. */
static void signal_while_waiting_for_input(int sig)
{
    char dir[PATH_MAX], fifo[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigwait") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    CHECK(mkfifo(fifo, 0600) == 0);
    if (harness_failures)
        return;
    const char *args[] = {harness_bin(), "-input", fifo, "-size", "8", "8", "-output", out,
                          NULL};
    int errfd = -1;
    pid_t pid = e2e_spawn(args, &errfd);
    CHECK(pid > 0);
    if (pid <= 0)
        return;
    alarm(120); /* should the open below never return */
    int fd = open(fifo, O_WRONLY);
    CHECK(fd >= 0);
    static const char part[] = "OrthographicCamera { center 0 0 10 ";
    CHECK(fd >= 0 && write(fd, part, sizeof part - 1) == (ssize_t)(sizeof part - 1));
    int unread = 1;
    for (int i = 0; i < 2000 && fd >= 0 && unread > 0; i++) { /* 20 s at most */
        if (ioctl(fd, FIONREAD, &unread) != 0)
            break;
        if (unread > 0)
            nanosleep(&(struct timespec){0, 10 * 1000 * 1000}, NULL);
    }
    CHECK_INT(unread, 0);
    kill(pid, sig);
    int st = 0;
    bool ended = e2e_wait_or_kill(pid, 20, &st);
    if (fd >= 0)
        close(fd);
    alarm(0);
    char err[4096];
    e2e_read_close(errfd, err, sizeof err);
    CHECK_MSG(ended, "still waiting for input 20 s after signal %d", sig);
    check_interrupted(ended, st, sig, err, out);
    e2e_rmtree(dir);
}

static void test_sigterm_waiting_for_input(void) { signal_while_waiting_for_input(SIGTERM); }
static void test_sigint_waiting_for_input(void) { signal_while_waiting_for_input(SIGINT); }

/* The same while the run waits to open an OBJ file that is a FIFO no one writes, with
 * -cache: the cache's look at the OBJ file's identity opened it too, and that open
 * waited for a writer where the stop flag was never looked at (the run was still
 * there 20 s after SIGTERM). The signal comes once the run waits in an open of the
 * FIFO (/proc/PID/wchan wait_for_partner; where that cannot be read, after 2 s). */
static void test_sigterm_waiting_for_obj(void)
{
    char dir[PATH_MAX], fifo[PATH_MAX], out[PATH_MAX], scene[PATH_MAX], cache[PATH_MAX];
    char wchan_path[64], wchan[64];
    CHECK(e2e_tmpdir(dir, sizeof dir, "sigwaitobj") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "mesh.obj");
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(cache, sizeof cache, dir, "set.cache");
    CHECK(mkfifo(fifo, 0600) == 0);
    CHECK(e2e_write_file(
        scene, "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
               "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
               "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mesh.obj } }\n"));
    if (harness_failures)
        return;
    const char *args[] = {harness_bin(), "-input", scene, "-size", "8", "8", "-output", out,
                          "-cache", cache, NULL};
    int errfd = -1;
    pid_t pid = e2e_spawn(args, &errfd);
    CHECK(pid > 0);
    if (pid <= 0)
        return;
    snprintf(wchan_path, sizeof wchan_path, "/proc/%d/wchan", (int)pid);
    bool waiting = false, readable = true;
    for (int i = 0; i < 2000 && !waiting && readable; i++) { /* 20 s at most */
        FILE *f = fopen(wchan_path, "r");
        size_t n = f ? fread(wchan, 1, sizeof wchan - 1, f) : 0;
        if (f)
            fclose(f);
        wchan[n] = '\0';
        readable = n > 0 && strcmp(wchan, "0") != 0;
        waiting = readable && strstr(wchan, "wait_for_partner") != NULL;
        if (!waiting)
            nanosleep(&(struct timespec){0, 10 * 1000 * 1000}, NULL);
    }
    if (!readable)
        nanosleep(&(struct timespec){2, 0}, NULL);
    kill(pid, SIGTERM);
    int st = 0;
    bool ended = e2e_wait_or_kill(pid, 20, &st);
    char err[4096];
    e2e_read_close(errfd, err, sizeof err);
    CHECK_MSG(ended, "still waiting for the OBJ file 20 s after SIGTERM");
    check_interrupted(ended, st, SIGTERM, err, out);
    CHECK_MSG(!e2e_exists(cache), "a set-up cache was written");
    e2e_rmtree(dir);
}

/* -cache naming a FIFO: no set-up cache (not a regular file, a warning) and the render
 * goes on. The cache's open waited for a writer for good, and ignored SIGTERM there
 * (the run was still there 20 s later). */
static void test_cache_is_fifo(void)
{
    char dir[PATH_MAX], fifo[PATH_MAX], out[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cachefifo") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "set.cache");
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    CHECK(mkfifo(fifo, 0600) == 0);
    CHECK(e2e_write_file(
        scene, "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
               "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
               "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n"));
    if (harness_failures)
        return;
    const char *args[] = {harness_bin(), "-input", scene, "-size", "8", "8", "-grid", "2",
                          "2", "2", "-output", out, "-cache", fifo, NULL};
    int errfd = -1;
    pid_t pid = e2e_spawn(args, &errfd);
    CHECK(pid > 0);
    if (pid <= 0)
        return;
    int st = 0;
    bool ended = e2e_wait_or_kill(pid, 20, &st);
    char err[4096];
    e2e_read_close(errfd, err, sizeof err);
    CHECK_MSG(ended, "still running 20 s after its start (waiting on the FIFO)");
    CHECK_MSG(ended && WIFEXITED(st) && WEXITSTATUS(st) == 0, "status %#x: %s", st, err);
    CHECK_CONTAINS(err, "not a regular file");
    CHECK_MSG(e2e_exists(out), "no image written");
    struct stat sb;
    CHECK(stat(fifo, &sb) == 0 && S_ISFIFO(sb.st_mode)); /* left as it is */
    e2e_rmtree(dir);
}

static void test_sigterm_while_streaming(void) { signal_while_streaming_as(SIGTERM, false); }
static void test_sigint_while_streaming(void) { signal_while_streaming_as(SIGINT, false); }
static void test_sigterm_while_streaming_film(void) { signal_while_streaming_as(SIGTERM, true); }

static void test_sigint_inside_pixel(void) { signal_inside_pixel(SIGINT); }
static void test_sigterm_inside_pixel(void) { signal_inside_pixel(SIGTERM); }

/* The depth image cannot be written: the colour image must not be written either, and
 * an older colour image keeps its bytes. */
static void test_outputs_all_or_nothing(void)
{
    char dir[PATH_MAX], out[PATH_MAX], depth[PATH_MAX], normals[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "allornothing") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(depth, sizeof depth, dir, "missing/d.tga");
    e2e_join(normals, sizeof normals, dir, "n.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    E2eRun r;
    const char *a1[] = {"-input", scene, "-output", out, "-normals", normals, "-depth", "0",
                        "1", depth, "-size", "8", "8", NULL};
    CHECK_INT(run(a1, &r), 1);
    CHECK_CONTAINS(r.err, "missing/d.tga");
    CHECK(!e2e_exists(out));
    CHECK(!e2e_exists(normals));
    CHECK_INT(e2e_count_entries(dir), 0);
    e2e_run_free(&r);

    CHECK(e2e_write_file(out, "old bytes"));
    CHECK_INT(run(a1, &r), 1);
    size_t len = 0;
    char *old = e2e_read_file(out, &len);
    CHECK_STR(old, "old bytes");
    free(old);
    CHECK_INT(e2e_count_entries(dir), 1);
    e2e_run_free(&r);

    /* and when every path is fine, all three are written */
    e2e_join(depth, sizeof depth, dir, "d.tga");
    const char *a2[] = {"-input", scene, "-output", out, "-normals", normals, "-depth", "0",
                        "1", depth, "-size", "8", "8", NULL};
    CHECK_INT(run(a2, &r), 0);
    CHECK_INT(e2e_count_entries(dir), 3);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* A file-size limit (ulimit -f, a batch system's quota) reached while an image is
 * written: exit 1 with "File too large", no image and no temporary file, and an older
 * image keeps its bytes. The limit (64 blocks: 32 or 64 KB) lets the header through but
 * not a 200x200 TGA (120 KB), so the failure comes mid-file: for the plain renderer's
 * streamed colour rows and for an antialiased render's strips (and its depth image).
 * Before the fix SIGXFSZ killed the run (exit 153, nothing said) with the temporary
 * file left behind. The limit is set in a shell that then runs the program, so it never
 * applies to this test's own output. */
static void test_file_size_limit(void)
{
    char dir[PATH_MAX], out[PATH_MAX], depth[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "fsize") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(depth, sizeof depth, dir, "d.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    char *plain[] = {"/bin/sh", "-c", "ulimit -f 64 && exec \"$0\" \"$@\"",
                     (char *)harness_bin(), "-input", scene, "-output", out, "-size", "200",
                     "200", "-threads", "2", NULL};
    char *film[] = {"/bin/sh", "-c", "ulimit -f 64 && exec \"$0\" \"$@\"",
                    (char *)harness_bin(), "-input", scene, "-output", out, "-depth", "0",
                    "20", depth, "-size", "200", "200", "-jittered_samples", "4",
                    "-threads", "2", NULL};
    char *const *runs[] = {plain, film};
    for (int i = 0; i < 2; i++) {
        E2eRun r;
        CHECK(e2e_run(runs[i], &r));
        CHECK_INT(r.status, 1);
        CHECK_CONTAINS(r.err, "File too large");
        CHECK_INT(e2e_count_entries(dir), 0);
        e2e_run_free(&r);
    }
    CHECK(e2e_write_file(out, "old bytes"));
    E2eRun r;
    CHECK(e2e_run(film, &r));
    CHECK_INT(r.status, 1);
    size_t len = 0;
    char *old = e2e_read_file(out, &len);
    CHECK_STR(old, "old bytes");
    free(old);
    CHECK_INT(e2e_count_entries(dir), 1);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* The percentage of the last "rendering N%" progress line in err, -1 when none. */
static int last_progress_percent(const char *err)
{
    int pct = -1;
    for (const char *p = strstr(err, "rendering"); p; p = strstr(p + 1, "rendering")) {
        int v;
        if (sscanf(p, "rendering %d%%", &v) == 1)
            pct = v;
    }
    return pct;
}

/* A write into a streamed image that fails during the render (here a file-size limit,
 * as a full disk would) stops the render at once: the same exit 1, "File too large",
 * and no file, but the final -progress line (which a stopped render ends with, at the
 * rows done) is far from 100%. The limit (64 blocks: 32 or 64 KB) is reached within
 * the first bands or strip of a 1000x1000 TGA (3 MB), for the plain renderer's colour
 * and an antialiased render's colour and depth. Before the fix the render went on to
 * the end ("rendering 100%") and only then reported the failed write. */
static void test_write_error_stops_render(void)
{
    char dir[PATH_MAX], out[PATH_MAX], depth[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "fstop") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(depth, sizeof depth, dir, "d.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    char *plain[] = {"/bin/sh", "-c", "ulimit -f 64 && exec \"$0\" \"$@\"",
                     (char *)harness_bin(), "-input", scene, "-output", out, "-size", "1000",
                     "1000", "-threads", "2", "-progress", NULL};
    char *film[] = {"/bin/sh", "-c", "ulimit -f 64 && exec \"$0\" \"$@\"",
                    (char *)harness_bin(), "-input", scene, "-output", out, "-depth", "0",
                    "20", depth, "-size", "1000", "1000", "-jittered_samples", "4",
                    "-threads", "2", "-progress", NULL};
    char *const *runs[] = {plain, film};
    for (int i = 0; i < 2; i++) {
        E2eRun r;
        CHECK(e2e_run(runs[i], &r));
        CHECK_INT(r.status, 1);
        CHECK_CONTAINS(r.err, "o.tga: error: cannot write image: File too large");
        int pct = last_progress_percent(r.err);
        CHECK_MSG(pct >= 0 && pct < 50, "run %d: the render was not cut short: %s", i, r.err);
        CHECK_INT(e2e_count_entries(dir), 0);
        e2e_run_free(&r);
    }
    e2e_rmtree(dir);
}

/* -gui_snapshot with a key script whose last shot cannot be written: exit 1 with the
 * reason and no image at all. The shot's folder was found missing only when the shot
 * came, after the r key had written -output (exit 1, one image written). */
static void test_snapshot_shot_checked_first(void)
{
    if (!preview_snapshot_built())
        harness_skip("built without OSMesa (apt-get install libosmesa6-dev, rebuild)");
    char dir[PATH_MAX], out[PATH_MAX], snap[PATH_MAX], scene[PATH_MAX], keys[2 * PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "snapshot") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(snap, sizeof snap, dir, "snap.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    snprintf(keys, sizeof keys, "r shot:%s/no/such/folder/x.tga", dir);
    E2eRun r;
    const char *a[] = {"-input", scene, "-size", "8", "8", "-output", out, "-gui_snapshot",
                       snap, "-gui_keys", keys, NULL};
    CHECK_INT(run(a, &r), 1);
    CHECK_CONTAINS(r.err, "no/such/folder/x.tga: error: cannot write image: folder");
    e2e_run_free(&r);
    CHECK_INT(e2e_count_entries(dir), 0);
    e2e_rmtree(dir);
}

/* Two outputs naming one file: a usage error (exit 2) before anything is rendered. */
static void test_same_path_twice(void)
{
    char dir[PATH_MAX], out[PATH_MAX], out2[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "samepath") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(out2, sizeof out2, dir, "./o.tga");
    repro(scene, sizeof scene, "planes_only.txt");
    E2eRun r;
    const char *a1[] = {"-input", scene, "-output", out, "-depth", "0", "1", out, NULL};
    CHECK_INT(run(a1, &r), 2);
    CHECK_CONTAINS(r.err, "same file");
    e2e_run_free(&r);
    const char *a2[] = {"-input", scene, "-normals", out, "-output", out2, NULL};
    CHECK_INT(run(a2, &r), 2);
    CHECK_CONTAINS(r.err, "same file");
    e2e_run_free(&r);
    CHECK_INT(e2e_count_entries(dir), 0);
    /* the set-up cache over the scene would destroy the scene: refused before it */
    const char *a4[] = {"-input", scene, "-output", out, "-cache", scene, NULL};
    CHECK_INT(run(a4, &r), 2);
    CHECK_CONTAINS(r.err, "-cache and -input name the same file");
    e2e_run_free(&r);
    CHECK_INT(e2e_count_entries(dir), 0);
    /* /dev/null twice is fine: nothing is replaced */
    const char *a3[] = {"-input", scene, "-output", out, "-depth", "0", "1", "/dev/null",
                        "-normals", "/dev/null", NULL};
    int st = run(a3, &r);
    CHECK_MSG(st != 2, "/dev/null twice refused: %s", r.err);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* Runs the binary with args (args[0] is the binary) and stdout on the given descriptor
 * (-1: closed); returns the exit status (128 + signal when killed) and the captured
 * stderr in err. */
static int run_argv_to(int out_fd, const char *const *args, char *err, size_t size)
{
    int errp[2];
    if (pipe(errp) != 0)
        return -1;
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_RDONLY);
        dup2(null, 0);
        if (out_fd >= 0)
            dup2(out_fd, 1);
        else
            close(1);
        dup2(errp[1], 2);
        close(errp[0]);
        /* The test harness may ignore SIGPIPE; the binary must cope with the default. */
        signal(SIGPIPE, SIG_DFL);
        execv(args[0], (char *const *)args);
        _exit(127);
    }
    close(errp[1]);
    size_t got = 0;
    ssize_t n;
    while (got + 1 < size && (n = read(errp[0], err + got, size - 1 - got)) > 0)
        got += (size_t)n;
    err[got] = '\0';
    close(errp[0]);
    int st = 0;
    while (waitpid(pid, &st, 0) < 0) {
    }
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* Runs with -stats and stdout on the given descriptor (-1: closed), as run_argv_to. */
static int run_stats_to(int out_fd, const char *scene, const char *out, char *err, size_t size)
{
    const char *args[] = {harness_bin(), "-input", scene, "-output", out, "-size", "8", "8",
                          "-stats", NULL};
    return run_argv_to(out_fd, args, err, size);
}

/* -h and --version whose text is lost (a full disk, stdout closed, a reader already
 * gone): exit 1 with a message naming what was lost, never 0 and never SIGPIPE. */
static void test_help_write_errors(void)
{
    static const char *const flags[][2] = {{"-h", "help text"}, {"--version", "version"}};
    char err[4096];
    for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++) {
        const char *args[] = {harness_bin(), flags[i][0], NULL};
        int full = open("/dev/full", O_WRONLY);
        if (full >= 0) {
            CHECK_INT(run_argv_to(full, args, err, sizeof err), 1);
            CHECK_CONTAINS(err, flags[i][1]);
            close(full);
        }
        CHECK_INT(run_argv_to(-1, args, err, sizeof err), 1);
        CHECK_CONTAINS(err, flags[i][1]);
        int p[2];
        CHECK(pipe(p) == 0);
        close(p[0]);
        CHECK_INT(run_argv_to(p[1], args, err, sizeof err), 1);
        CHECK_CONTAINS(err, flags[i][1]);
        close(p[1]);
    }
}

/* -stats whose output is lost: exit 1 with a message, never 0 and never SIGPIPE. */
static void test_stats_write_errors(void)
{
    char dir[PATH_MAX], out[PATH_MAX], scene[PATH_MAX], err[4096];
    CHECK(e2e_tmpdir(dir, sizeof dir, "statserr") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    repro(scene, sizeof scene, "planes_only.txt");

    int full = open("/dev/full", O_WRONLY);
    if (full >= 0) {
        CHECK_INT(run_stats_to(full, scene, out, err, sizeof err), 1);
        CHECK_CONTAINS(err, "statistics");
        close(full);
    }
    CHECK_INT(run_stats_to(-1, scene, out, err, sizeof err), 1);
    CHECK_CONTAINS(err, "statistics");

    /* A reader that is already gone: the read end is closed before the run starts. */
    int p[2];
    CHECK(pipe(p) == 0);
    close(p[0]);
    CHECK_INT(run_stats_to(p[1], scene, out, err, sizeof err), 1);
    CHECK_CONTAINS(err, "statistics");
    close(p[1]);
    e2e_rmtree(dir);
}

/* Runs args plus the grid arguments grid (NULL-terminated; NULL: none) with -output out;
 * returns the exit status with the run in r. */
static int run_grid(const char *scene, const char *out, const char *const *grid, E2eRun *r)
{
    const char *args[24] = {"-input", scene, "-output", out, "-size", "20", "20", "-shadows"};
    int n = 8;
    for (int k = 0; grid && grid[k]; k++)
        args[n++] = grid[k];
    args[n] = NULL;
    return run(args, r);
}

static bool same_file(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *x = e2e_read_file(a, &la), *y = e2e_read_file(b, &lb);
    bool same = x && y && la == lb && memcmp(x, y, la) == 0;
    free(x);
    free(y);
    return same;
}

/* The grid reproducers: huge bounds (a sphere of radius 3e38, a triangle at +-3e38)
 * were refused by -grid with an unlocated "bounding box is not finite"; 10,000 spheres at
 * one point took 13 s and 590 MB with -grid auto. Every grid choice now renders them
 * (exit 0) to the bytes of the run without a grid; the huge objects get a warning at
 * the line of the object, and the piled-up spheres a coarser grid (the cap's warning for
 * an explicit resolution, none for auto). */
static void test_repro_grid_scenes(void)
{
    static const char *const scenes[] = {"grid_refuses_big_radius.txt",
                                         "grid_refuses_big_triangle.txt",
                                         "grid_auto_colocated_10000.txt"};
    static const char *const grids[][5] = {{"-grid", "auto", NULL},
                                           {"-grid", "64", "64", "64", NULL},
                                           {"-accel", "grid", "-grid", "auto", NULL},
                                           {"-accel", "twolevel", NULL}};
    char dir[PATH_MAX], out[PATH_MAX], ref[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "gridrepro") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    for (int i = 0; i < 3; i++) {
        repro(scene, sizeof scene, scenes[i]);
        E2eRun r;
        char why[512];
        CHECK_MSG(run_grid(scene, ref, NULL, &r) == 0, "%s (no grid): %s", scenes[i],
                  e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        for (int g = 0; g < 4; g++) {
            int st = run_grid(scene, out, grids[g], &r);
            CHECK_MSG(st == 0, "%s %s %s: %s", scenes[i], grids[g][0], grids[g][1],
                      e2e_describe(&r, why, sizeof why));
            CHECK_MSG(same_file(out, ref), "%s %s %s: the image differs from the one "
                      "without a grid", scenes[i], grids[g][0], grids[g][1]);
            if (i < 2) {
                char loc[PATH_MAX + 128];
                snprintf(loc, sizeof loc, "%s:5:38: warning: %s reaches beyond", scene,
                         i == 0 ? "Sphere" : "Triangle");
                CHECK_CONTAINS(r.err, loc);
                CHECK_CONTAINS(r.err, "kept out of the grid");
                CHECK(strstr(r.err, "not finite") == NULL);
            } else if (g == 1) {
                CHECK_CONTAINS(r.err, "a 64x64x64 grid would exceed");
            } else {
                CHECK(r.err == NULL || strstr(r.err, "warning") == NULL);
            }
            e2e_run_free(&r);
        }
    }
    e2e_rmtree(dir);
}

/* Huge objects among ordinary ones (a huge sphere behind small spheres and a mesh-like
 * row of triangles, a huge triangle under a Transform): the ordinary ones still go
 * into the grid, the image and the intersections found are those without a grid, and
 * the warning names the first huge object's line and counts the others. */
static void test_huge_among_small(void)
{
    static const char text[] =
        "PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }\n"
        "Lights { numLights 1 PointLight { position 0 5 5 color 1 1 1 } }\n"
        "Materials { numMaterials 2 PhongMaterial { diffuseColor 1 0 0 }\n"
        "  PhongMaterial { diffuseColor 0 1 0 reflectiveColor 0.3 0.3 0.3 } }\n"
        "Background { color 0 0 0.2 ambientLight 0.1 0.1 0.1 }\n"
        "Group { numObjects 7 MaterialIndex 0\n"
        "  Sphere { center -1 0 0 radius 0.5 }\n"
        "  Sphere { center 1 0 0 radius 0.5 }\n"
        "  MaterialIndex 1\n"
        "  Sphere { center 0 0 -1e36 radius 3e36 }\n"
        "  Triangle { vertex0 -1 -1 1 vertex1 1 -1 1 vertex2 0 1 1 }\n"
        "  Transform { Scale 2 2 2\n"
        "    Triangle { vertex0 -3e37 -2 -3 vertex1 3e37 -2 -3 vertex2 0 -2 3e37 } }\n"
        "  Sphere { center 0 1 0 radius 0.25 }\n"
        "  Sphere { center 0 -1 0 radius 0.25 }\n"
        "}\n";
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX], ref[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "hugemix") != NULL);
    e2e_join(scene, sizeof scene, dir, "mix.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    CHECK(e2e_write_file(scene, text));
    static const char *const none[] = {"-bounces", "2", NULL};
    static const char *const grids[][8] = {{"-bounces", "2", "-grid", "auto", NULL},
                                           {"-bounces", "2", "-grid", "8", "8", "8", NULL},
                                           {"-bounces", "2", "-grid", "8", "8", "8",
                                            "-no_packets", NULL}};
    E2eRun r;
    char why[512];
    CHECK_MSG(run_grid(scene, ref, none, &r) == 0, "no grid: %s",
              e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    for (int g = 0; g < 3; g++) {
        CHECK_MSG(run_grid(scene, out, grids[g], &r) == 0, "grid %d: %s", g,
                  e2e_describe(&r, why, sizeof why));
        CHECK_MSG(same_file(out, ref), "grid %d: the image differs from the one without", g);
        char loc[PATH_MAX + 128];
        snprintf(loc, sizeof loc, "%s:10:3: warning: Sphere reaches beyond", scene);
        CHECK_CONTAINS(r.err, loc);
        CHECK_CONTAINS(r.err, "(and 1 more objects)");
        CHECK(strstr(r.err, "nothing bounded") == NULL);
        e2e_run_free(&r);
    }
    /* The ordinary objects are in cells: the grid tests fewer of them per ray than the
     * brute force (7 per ray). */
    const char *const stats[] = {"-input", scene, "-output", out, "-size", "20", "20",
                                 "-grid", "8", "8", "8", "-stats", NULL};
    CHECK_INT(run(stats, &r), 0);
    E2eStats st;
    CHECK(r.out && e2e_stats_parse(r.out, &st));
    if (r.out && e2e_stats_parse(r.out, &st))
        CHECK_MSG(st.intersections < 7ull * st.nonshadow, "%llu intersections for %llu rays",
                  (unsigned long long)st.intersections, (unsigned long long)st.nonshadow);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* A scene whose Group has no children (and one with only an empty Transform) renders
 * its background with every accelerator choice and says why there is no grid: the
 * primitive table is empty and has no array, which once reached pointer arithmetic that
 * clang's UBSan flags (the scene fuzz target found it). */
static void test_empty_scene(void)
{
    static const char *const texts[] = {
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Background { color 0.2 0.4 0.6 }\n"
        "Group { numObjects 0 }\n",
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Background { color 0.2 0.4 0.6 }\n"
        "Group { numObjects 1 Transform { Scale 2 2 2 Group { numObjects 0 } } }\n",
    };
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX], ref[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "empty") != NULL);
    e2e_join(scene, sizeof scene, dir, "empty.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    static const char *const grids[][8] = {{"-grid", "auto", NULL},
                                           {"-grid", "3", "3", "3", NULL},
                                           {"-grid", "3", "3", "3", "-no_packets", NULL},
                                           {"-accel", "none", NULL}};
    E2eRun r;
    char why[512];
    for (int k = 0; k < 2; k++) {
        CHECK(e2e_write_file(scene, texts[k]));
        CHECK_MSG(run_grid(scene, ref, NULL, &r) == 0, "scene %d, no grid: %s", k,
                  e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        size_t len = 0;
        unsigned char *img = (unsigned char *)e2e_read_file(ref, &len);
        /* An uncompressed 20x20 TGA of the background colour (BGR 153 102 51). */
        CHECK_MSG(img && len >= 18 + 20 * 20 * 3, "scene %d: no image", k);
        CHECK_MSG(img && len > 2 && img[2] == 2, "scene %d: not an uncompressed TGA", k);
        if (img && len >= 18 + 20 * 20 * 3 && img[2] == 2)
            for (size_t i = 18; i < 18 + 20 * 20 * 3; i += 3)
                CHECK_MSG(img[i] == 153 && img[i + 1] == 102 && img[i + 2] == 51,
                          "scene %d: pixel %zu is not the background", k, (i - 18) / 3);
        free(img);
        for (int g = 0; g < 4; g++) {
            CHECK_MSG(run_grid(scene, out, grids[g], &r) == 0, "scene %d, choice %d: %s", k, g,
                      e2e_describe(&r, why, sizeof why));
            CHECK_MSG(same_file(out, ref), "scene %d, choice %d: the image differs", k, g);
            if (g < 3)
                CHECK_CONTAINS(r.err, "the scene has no objects: rendering without a");
            e2e_run_free(&r);
        }
    }
    e2e_rmtree(dir);
}

/* One grid-size limit, checked with the options: 2048 x 2048 x 16 (64 M cells) once
 * passed the option check and failed later with exit 1 and no location. */
static void test_grid_limit_with_options(void)
{
    char scene[PATH_MAX];
    repro(scene, sizeof scene, "planes_only.txt");
    E2eRun r;
    const char *a1[] = {"-input", scene, "-grid", "2048", "2048", "16", NULL};
    CHECK_INT(run(a1, &r), 2);
    CHECK_CONTAINS(r.err, "cells, the limit is 16777216");
    e2e_run_free(&r);
    const char *a2[] = {"-input", scene, "-grid", "256", "256", "256", "-size", "4", "4", "-stats",
                        NULL};
    CHECK_INT(run(a2, &r), 0); /* exactly the limit: accepted (only planes: no grid) */
    e2e_run_free(&r);
}

/* Reflected and refracted rays go on as packets of the next depth, each depth's
 * packet state on the stack (about 27 KB a depth). Under a small stack limit (ulimit -s 128,
 * which the render threads' stacks follow) they are traced one by one, as before: a
 * deep -bounces between two mirrors, which fits one by one, must still render, and the
 * same bytes as with the default stack. With packets at every depth it overflowed the
 * stack (SIGSEGV, seen). Not under the sanitizers, whose frames are larger. */
static void test_deep_bounces_small_stack(void)
{
    if (E2E_SANITIZED)
        harness_skip("the sanitizers' stack frames do not fit under ulimit -s 128");
    char dir[PATH_MAX], small[PATH_MAX], dflt[PATH_MAX], scene[PATH_MAX], why[512];
    snprintf(scene, sizeof scene, "%s/scenes/feat_mirrors.txt", harness_root());
    CHECK(e2e_tmpdir(dir, sizeof dir, "stack") != NULL);
    e2e_join(small, sizeof small, dir, "small.tga");
    e2e_join(dflt, sizeof dflt, dir, "default.tga");
    for (int k = 0; k < 2; k++) {
        char *args[] = {"/bin/sh", "-c",
                        k == 0 ? "ulimit -s 128 && exec \"$0\" \"$@\"" : "exec \"$0\" \"$@\"",
                        (char *)harness_bin(), "-input", scene, "-output", k == 0 ? small : dflt,
                        "-size", "40", "40", "-shadows", "-bounces", "200", "-weight", "0",
                        "-grid", "10", "10", "10", "-threads", "2", NULL};
        E2eRun r;
        CHECK(e2e_run(args, &r));
        CHECK_MSG(r.status == 0, "-bounces 200 between mirrors%s: %s",
                  k == 0 ? " under ulimit -s 128" : "", e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
    }
    size_t a_len = 0, b_len = 0;
    char *a = e2e_read_file(small, &a_len), *b = e2e_read_file(dflt, &b_len);
    CHECK_MSG(a && b && a_len == b_len && a_len == 18 + 40 * 40 * 3 && !memcmp(a, b, a_len),
              "the image under the small stack is the default stack's");
    free(a);
    free(b);
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"deep_bounces_small_stack", test_deep_bounces_small_stack},
    {"repro_grid_scenes", test_repro_grid_scenes},
    {"huge_among_small", test_huge_among_small},
    {"grid_limit_with_options", test_grid_limit_with_options},
    {"empty_scene", test_empty_scene},
    {"sigterm_during_write", test_sigterm_during_write},
    {"sighup_during_write", test_sighup_during_write},
    {"sighup_ignored_like_nohup", test_sighup_ignored_like_nohup},
    {"sigint_ignored_in_background", test_sigint_ignored_in_background},
    {"sigint_during_write", test_sigint_during_write},
    {"sigint_inside_pixel", test_sigint_inside_pixel},
    {"sigterm_inside_pixel", test_sigterm_inside_pixel},
    {"sigterm_while_streaming", test_sigterm_while_streaming},
    {"sigint_while_streaming", test_sigint_while_streaming},
    {"sigterm_while_streaming_film", test_sigterm_while_streaming_film},
    {"sigterm_before_snapshot", test_sigterm_before_snapshot},
    {"sigterm_during_merge", test_sigterm_during_merge},
    {"sigint_during_merge", test_sigint_during_merge},
    {"sigterm_during_setup", test_sigterm_during_setup},
    {"sigterm_during_obj_parse", test_sigterm_during_obj_parse},
    {"sigterm_during_obj_read", test_sigterm_during_obj_read},
    {"sigterm_waiting_for_input", test_sigterm_waiting_for_input},
    {"sigint_waiting_for_input", test_sigint_waiting_for_input},
    {"sigterm_waiting_for_obj", test_sigterm_waiting_for_obj},
    {"cache_is_fifo", test_cache_is_fifo},
    {"outputs_all_or_nothing", test_outputs_all_or_nothing},
    {"file_size_limit", test_file_size_limit},
    {"write_error_stops_render", test_write_error_stops_render},
    {"same_path_twice", test_same_path_twice},
    {"snapshot_shot_checked_first", test_snapshot_shot_checked_first},
    {"stats_write_errors", test_stats_write_errors},
    {"help_write_errors", test_help_write_errors},
};
RT_TEST_MAIN(tests)
