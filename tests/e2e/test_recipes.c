/* The split-render recipes of README.txt section 8, end to end: GNU parallel (locally,
 * and in the across-machines form with the local machine as the only login), the Slurm
 * scripts in their fallback mode (no Slurm: a plain loop, mpirun), and tiles.sbatch's
 * array mode driven by Slurm's variables with a stand-in sbatch. Each result must be the
 * whole render's bytes. Tools that are missing skip their test, unless RT_REQUIRE_MPI=1
 * (CI installs them all). */
#define _POSIX_C_SOURCE 200809L
#include "../harness.h"
#include "e2e_util.h"

static const char SCENE[] =
    "PerspectiveCamera { center 0 1 8 direction 0 -0.1 -1 up 0 1 0 angle 35 }\n"
    "Lights { numLights 1 DirectionalLight { direction -0.5 -1 -0.5 color 1 1 1 } }\n"
    "Background { color 0.2 0.3 0.4 ambientLight 0.1 0.1 0.1 }\n"
    "Materials { numMaterials 2\n"
    "  PhongMaterial { diffuseColor 0.9 0.2 0.2 specularColor 1 1 1 exponent 20 }\n"
    "  PhongMaterial { diffuseColor 0.5 0.5 0.5 reflectiveColor 0.3 0.3 0.3 } }\n"
    "Group { numObjects 3\n"
    "  MaterialIndex 0 Sphere { center -1 0.5 0 radius 1 }\n"
    "  Sphere { center 1.2 0.3 -1 radius 0.8 }\n"
    "  MaterialIndex 1 Plane { normal 0 1 0 offset -0.5 } }\n";

static const char *const SIZE_W = "96", *const SIZE_H = "72";

/* A folder with the scene and the whole render (ref.tga), made with the binary. */
typedef struct Setup {
    char dir[PATH_MAX], scene[PATH_MAX], ref[PATH_MAX], bin[PATH_MAX], root[PATH_MAX];
} Setup;

static bool setup(Setup *s, const char *tag)
{
    CHECK(e2e_tmpdir(s->dir, sizeof s->dir, tag) != NULL);
    e2e_join(s->scene, sizeof s->scene, s->dir, "scene.txt");
    e2e_join(s->ref, sizeof s->ref, s->dir, "ref.tga");
    CHECK(e2e_write_file(s->scene, SCENE));
    CHECK(e2e_abspath(harness_bin(), s->bin, sizeof s->bin));
    CHECK(e2e_abspath(harness_root(), s->root, sizeof s->root));
    const char *args[] = {"-input", s->scene, "-size", SIZE_W, SIZE_H, "-shadows", "-bounces",
                          "2", "-output", s->ref, NULL};
    E2eRun r;
    char why[512];
    bool ok = e2e_run_bin(harness_bin(), args, &r) && r.status == 0;
    CHECK_MSG(ok, "whole render: %s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    /* Never let a Slurm environment of the machine running the tests leak in. */
    unsetenv("SLURM_JOB_ID");
    unsetenv("SLURM_ARRAY_JOB_ID");
    return ok && !harness_failures;
}

static bool same_file(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *da = e2e_read_file(a, &la), *db = e2e_read_file(b, &lb);
    bool same = da && db && la == lb && memcmp(da, db, la) == 0;
    free(da);
    free(db);
    return same;
}

/* Runs a shell command in dir; true on exit status 0. */
static bool shell(const char *dir, const char *cmd, E2eRun *r)
{
    char full[8 * PATH_MAX];
    snprintf(full, sizeof full, "cd '%s' && %s", dir, cmd);
    char *argv[] = {(char *)"/bin/sh", (char *)"-c", full, NULL};
    if (!e2e_run(argv, r))
        return false;
    char why[1024];
    CHECK_MSG(r->status == 0, "'%s': %s", cmd, e2e_describe(r, why, sizeof why));
    return r->status == 0;
}

/* Runs cmd in the set-up's folder; when it exits 0, the frame.tga it made must be the
 * whole render's bytes. True when the command succeeded. */
static bool run_recipe(const Setup *s, const char *cmd, const char *what)
{
    E2eRun r;
    bool ok = shell(s->dir, cmd, &r);
    if (ok) {
        char out[PATH_MAX];
        CHECK_MSG(same_file(e2e_join(out, sizeof out, s->dir, "frame.tga"), s->ref),
                  "%s: frame differs from the whole render", what);
    }
    e2e_run_free(&r);
    return ok;
}

static bool have(const char *tool)
{
    char cmd[256];
    snprintf(cmd, sizeof cmd, "command -v %s >/dev/null 2>&1", tool);
    char *argv[] = {(char *)"/bin/sh", (char *)"-c", cmd, NULL};
    E2eRun r;
    bool ok = e2e_run(argv, &r) && r.status == 0;
    e2e_run_free(&r);
    return ok;
}

static void need(const char *tool, const char *package)
{
    if (have(tool))
        return;
    const char *req = getenv("RT_REQUIRE_MPI");
    char why[256];
    snprintf(why, sizeof why, "%s not installed (apt-get install %s)", tool, package);
    if (req && strcmp(req, "1") == 0) {
        harness_fail(__FILE__, __LINE__, "RT_REQUIRE_MPI=1 but %s", why);
        fflush(stdout);
        _exit(1);
    }
    harness_skip(why);
}

static void test_parallel_one_machine(void)
{
    need("parallel", "parallel");
    Setup s;
    if (!setup(&s, "parallel"))
        return;
    char cmd[6 * PATH_MAX];
    snprintf(cmd, sizeof cmd,
             "parallel '%s' -input scene.txt -size %s %s -shadows -bounces 2 -tile {} 8 "
             "-output part{}.tga ::: 0 1 2 3 4 5 6 7 && '%s' -merge frame.tga part?.tga",
             s.bin, SIZE_W, SIZE_H, s.bin);
    run_recipe(&s, cmd, "GNU parallel");
    e2e_rmtree(s.dir);
}

/* The across-machines form of README.txt with ":" (this machine) as the login. */
static void test_parallel_sshlogin_form(void)
{
    need("parallel", "parallel");
    Setup s;
    if (!setup(&s, "parssh"))
        return;
    char cmd[6 * PATH_MAX];
    snprintf(cmd, sizeof cmd,
             "parallel --sshlogin 2/: --basefile scene.txt --workdir . --return part{}.tga "
             "--cleanup '%s' -input scene.txt -size %s %s -shadows -bounces 2 -tile {} 5 "
             "-output part{}.tga ::: 0 1 2 3 4 && '%s' -merge frame.tga part*.tga",
             s.bin, SIZE_W, SIZE_H, s.bin);
    run_recipe(&s, cmd, "parallel --sshlogin");
    e2e_rmtree(s.dir);
}

static void test_tiles_sbatch_fallback(void)
{
    need("bash", "bash");
    Setup s;
    if (!setup(&s, "tilesfb"))
        return;
    char cmd[6 * PATH_MAX];
    snprintf(cmd, sizeof cmd,
             "TILES=6 RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' scene.txt frame.tga "
             "-size %s %s -shadows -bounces 2", s.bin, s.root, SIZE_W, SIZE_H);
    if (run_recipe(&s, cmd, "tiles.sbatch (no Slurm)"))
        CHECK_MSG(e2e_count_entries(s.dir) == 3, "tiles.sbatch left its parts behind");
    /* A folder left by another run (the old shared name frame.tga.parts, with a stale
     * part of a 6-band split) is not this job's: it is neither read nor removed. */
    char stale[PATH_MAX], stale_part[PATH_MAX];
    e2e_join(stale, sizeof stale, s.dir, "frame.tga.parts");
    CHECK(mkdir(stale, 0755) == 0);
    CHECK(e2e_write_file(e2e_join(stale_part, sizeof stale_part, stale, "part5.tga"), "x"));
    snprintf(cmd, sizeof cmd,
             "TILES=3 RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' scene.txt frame.tga "
             "-size %s %s -shadows -bounces 2", s.bin, s.root, SIZE_W, SIZE_H);
    if (run_recipe(&s, cmd, "tiles.sbatch (no Slurm, 3 bands, a stale folder)"))
        CHECK_MSG(e2e_count_entries(s.dir) == 4 && e2e_exists(stale_part),
                  "tiles.sbatch touched another run's folder or left its own");
    e2e_rmtree(stale);
    /* TILE_COLS: a grid of 2 columns x 3 rows instead of 6 bands, the same image */
    snprintf(cmd, sizeof cmd,
             "TILES=6 TILE_COLS=2 RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' "
             "scene.txt frame.tga -size %s %s -shadows -bounces 2", s.bin, s.root, SIZE_W,
             SIZE_H);
    if (run_recipe(&s, cmd, "tiles.sbatch (no Slurm, a 2x3 grid)"))
        CHECK_MSG(e2e_count_entries(s.dir) == 3, "tiles.sbatch left its parts behind");
    /* 6 tiles do not make whole rows of 4 columns: refused before anything runs */
    E2eRun g;
    snprintf(cmd, sizeof cmd,
             "TILES=6 TILE_COLS=4 RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' "
             "scene.txt other.tga -size %s %s", s.bin, s.root, SIZE_W, SIZE_H);
    char gfull[8 * PATH_MAX];
    snprintf(gfull, sizeof gfull, "cd '%s' && %s", s.dir, cmd);
    char *gargv[] = {(char *)"/bin/sh", (char *)"-c", gfull, NULL};
    CHECK(e2e_run(gargv, &g));
    CHECK_MSG(g.status == 2, "tiles.sbatch with TILE_COLS=4 of 6: exit %d, expected 2",
              g.status);
    CHECK_CONTAINS(g.err, "TILE_COLS=4");
    e2e_run_free(&g);
    /* TILES not a count: refused naming it (bash stopped on 'x: unbound variable' in
     * its loop, and TILES=0 merged no parts) */
    static const char *const bad_tiles[] = {"x", "0", "-2"};
    for (int i = 0; i < 3; i++) {
        snprintf(cmd, sizeof cmd,
                 "TILES=%s RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' "
                 "scene.txt other.tga -size %s %s", bad_tiles[i], s.bin, s.root, SIZE_W,
                 SIZE_H);
        snprintf(gfull, sizeof gfull, "cd '%s' && %s", s.dir, cmd);
        CHECK(e2e_run(gargv, &g));
        char want[32];
        snprintf(want, sizeof want, "TILES=%s: expected a count", bad_tiles[i]);
        const char *nl = strchr(g.err, '\n');
        CHECK_MSG(g.status == 2 && strstr(g.err, want) && nl && !nl[1],
                  "tiles.sbatch with TILES=%s: exit %d, stderr:\n%s", bad_tiles[i], g.status,
                  g.err);
        e2e_run_free(&g);
    }
    /* -tile and -region are the script's: refused (status 2) before anything runs */
    static const char *const own[] = {"-tile 0 2", "-region 0 0 8 8"};
    E2eRun r;
    for (int i = 0; i < 2; i++) {
        snprintf(cmd, sizeof cmd,
                 "RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' scene.txt other.tga "
                 "-size %s %s %s", s.bin, s.root, SIZE_W, SIZE_H, own[i]);
        char full[8 * PATH_MAX];
        snprintf(full, sizeof full, "cd '%s' && %s", s.dir, cmd);
        char *argv[] = {(char *)"/bin/sh", (char *)"-c", full, NULL};
        CHECK(e2e_run(argv, &r));
        CHECK_MSG(r.status == 2, "tiles.sbatch with %s: exit %d, expected 2", own[i], r.status);
        CHECK_CONTAINS(r.err, "give no -tile or -region");
        e2e_run_free(&r);
    }
    /* a failed run (a scene error) removes its parts folder too */
    char bad[PATH_MAX];
    CHECK(e2e_write_file(e2e_join(bad, sizeof bad, s.dir, "bad.txt"), "garbage\n"));
    snprintf(cmd, sizeof cmd,
             "cd '%s' && RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' bad.txt other.tga "
             "-size %s %s", s.dir, s.bin, s.root, SIZE_W, SIZE_H);
    char *argv[] = {(char *)"/bin/sh", (char *)"-c", cmd, NULL};
    CHECK(e2e_run(argv, &r));
    CHECK_MSG(r.status == 1, "tiles.sbatch with a bad scene: exit %d, expected 1", r.status);
    e2e_run_free(&r);
    CHECK_MSG(e2e_count_entries(s.dir) == 4, "a failed tiles.sbatch left its parts behind");
    e2e_rmtree(s.dir);
}

/* The whole render's depth and normal images (-depth 7 10), made with the binary. */
static bool render_aovs(const Setup *s, char *depth, char *normals)
{
    e2e_join(depth, PATH_MAX, s->dir, "ref_depth.tga");
    e2e_join(normals, PATH_MAX, s->dir, "ref_normals.tga");
    const char *args[] = {"-input", s->scene, "-size", SIZE_W, SIZE_H, "-shadows",
                          "-bounces", "2", "-depth", "7", "10", depth, "-normals", normals,
                          NULL};
    E2eRun r;
    char why[512];
    bool ok = e2e_run_bin(harness_bin(), args, &r) && r.status == 0;
    CHECK_MSG(ok, "whole depth and normals: %s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    return ok;
}

/* -depth and -normals given to tiles.sbatch: each is rendered in bands beside the parts
 * and merged into its file, the whole render's bytes (passed on as they were, every
 * band wrote its own band into the one file, and the last band was left there as the
 * image, exit 0); -output is the script's second argument, so giving it is refused. */
static void test_tiles_sbatch_depth_normals(void)
{
    need("bash", "bash");
    Setup s;
    if (!setup(&s, "tilesaov"))
        return;
    char ref_depth[PATH_MAX], ref_normals[PATH_MAX];
    if (!render_aovs(&s, ref_depth, ref_normals)) {
        e2e_rmtree(s.dir);
        return;
    }
    char cmd[6 * PATH_MAX], path[PATH_MAX];
    snprintf(cmd, sizeof cmd,
             "TILES=3 RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' scene.txt frame.tga "
             "-size %s %s -shadows -depth 7 10 d.tga -bounces 2 -normals n.tga", s.bin, s.root,
             SIZE_W, SIZE_H);
    if (run_recipe(&s, cmd, "tiles.sbatch -depth -normals (no Slurm)")) {
        CHECK_MSG(same_file(e2e_join(path, sizeof path, s.dir, "d.tga"), ref_depth),
                  "tiles.sbatch: the -depth image is not the whole render's");
        CHECK_MSG(same_file(e2e_join(path, sizeof path, s.dir, "n.tga"), ref_normals),
                  "tiles.sbatch: the -normals image is not the whole render's");
        /* scene, ref, ref_depth, ref_normals, frame, d, n: no parts folder */
        CHECK_MSG(e2e_count_entries(s.dir) == 7, "tiles.sbatch left its parts behind");
    }
    /* refused before anything runs: -output, and two merges into one file */
    static const char *const bad[][2] = {
        {"-output x.tga", "give no -output"},
        {"-depth 7 10 x.tga -normals x.tga", "must name different files"},
    };
    for (int i = 0; i < 2; i++) {
        E2eRun r;
        snprintf(cmd, sizeof cmd,
                 "cd '%s' && RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' scene.txt "
                 "other.tga -size %s %s %s", s.dir, s.bin, s.root, SIZE_W, SIZE_H, bad[i][0]);
        char *argv[] = {(char *)"/bin/sh", (char *)"-c", cmd, NULL};
        CHECK(e2e_run(argv, &r));
        CHECK_MSG(r.status == 2, "tiles.sbatch with %s: exit %d, expected 2", bad[i][0],
                  r.status);
        CHECK_CONTAINS(r.err, bad[i][1]);
        e2e_run_free(&r);
        CHECK_MSG(!e2e_exists(e2e_join(path, sizeof path, s.dir, "x.tga")) &&
                      e2e_count_entries(s.dir) == 7,
                  "tiles.sbatch with %s wrote something", bad[i][0]);
    }
    /* A merged image that cannot be written is refused before any band is rendered
     * (no band's -stats block on stdout): it was found only by the merge, after every
     * band (under Slurm, after the whole array), and -depth's and -normals' names,
     * which the bands no longer write, only there too. */
    static const char *const late[][3] = {
        {"frame.jpg", "", "2"},
        {"nodir/frame.tga", "", "1"},
        {"other.tga", "-depth 7 10 d.jpg", "2"},
        {"other.tga", "-normals nodir/n.tga", "1"},
    };
    for (int i = 0; i < 4; i++) {
        E2eRun r;
        snprintf(cmd, sizeof cmd,
                 "cd '%s' && RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' scene.txt "
                 "%s -size %s %s -stats %s", s.dir, s.bin, s.root, late[i][0], SIZE_W, SIZE_H,
                 late[i][1]);
        char *argv[] = {(char *)"/bin/sh", (char *)"-c", cmd, NULL};
        CHECK(e2e_run(argv, &r));
        CHECK_MSG(r.status == atoi(late[i][2]) && r.out_len == 0 && strchr(r.err, '\n') &&
                      !strchr(r.err, '\n')[1],
                  "tiles.sbatch %s %s: exit %d (expected %s), stdout:\n%.300s\nstderr:\n%s",
                  late[i][0], late[i][1], r.status, late[i][2], r.out, r.err);
        e2e_run_free(&r);
        CHECK_MSG(e2e_count_entries(s.dir) == 7, "tiles.sbatch %s %s left something behind",
                  late[i][0], late[i][1]);
    }
    e2e_rmtree(s.dir);
}

/* The array path as Slurm runs it: one run per task with Slurm's variables (in a
 * scrambled order), a stand-in sbatch that records the merge job it is given, then
 * that job's command. */
static void test_tiles_sbatch_array_mode(void)
{
    need("bash", "bash");
    Setup s;
    if (!setup(&s, "tilesarr"))
        return;
    char fake[PATH_MAX], cmd[6 * PATH_MAX];
    e2e_join(fake, sizeof fake, s.dir, "sbatch");
    CHECK(e2e_write_file(fake, "#!/bin/sh\nprintf '%s\\n' \"$@\" > sbatch.args\n"));
    CHECK(chmod(fake, 0755) == 0);
    static const int order[4] = {2, 0, 3, 1};
    E2eRun r;
    for (int i = 0; i < 4 && !harness_failures; i++) {
        snprintf(cmd, sizeof cmd,
                 "PATH=\"$PWD:$PATH\" SLURM_ARRAY_JOB_ID=4242 SLURM_ARRAY_TASK_MIN=10 "
                 "SLURM_ARRAY_TASK_COUNT=4 SLURM_ARRAY_TASK_ID=%d RAYTRACER='%s' "
                 "bash '%s/scripts/slurm/tiles.sbatch' scene.txt frame.tga -size %s %s "
                 "-shadows -bounces 2 -depth 7 10 d.tga -normals n.tga", 10 + order[i],
                 s.bin, s.root, SIZE_W, SIZE_H);
        shell(s.dir, cmd, &r);
        e2e_run_free(&r);
    }
    char args_path[PATH_MAX];
    char *args = e2e_read_file(e2e_join(args_path, sizeof args_path, s.dir, "sbatch.args"),
                               NULL);
    CHECK_MSG(args != NULL, "the first task did not submit the merge job");
    if (args) {
        CHECK_CONTAINS(args, "--dependency=afterok:4242\n");
        const char *wrap = strstr(args, "--wrap=");
        CHECK(wrap != NULL);
        if (wrap) {
            char merge[2048];
            snprintf(merge, sizeof merge, "%s", wrap + 7);
            merge[strcspn(merge, "\n")] = '\0';
            char parts[PATH_MAX];
            e2e_join(parts, sizeof parts, s.dir, "frame.tga.parts.4242");
            CHECK_MSG(e2e_exists(parts), "the array job's parts are not in frame.tga.parts.4242");
            char ref_depth[PATH_MAX], ref_normals[PATH_MAX], path[PATH_MAX];
            if (run_recipe(&s, merge, "tiles.sbatch (array), merge job") &&
                render_aovs(&s, ref_depth, ref_normals)) {
                CHECK_MSG(same_file(e2e_join(path, sizeof path, s.dir, "d.tga"), ref_depth),
                          "tiles.sbatch (array): the -depth image is not the whole render's");
                CHECK_MSG(same_file(e2e_join(path, sizeof path, s.dir, "n.tga"), ref_normals),
                          "tiles.sbatch (array): the -normals image is not the whole "
                          "render's");
            }
            CHECK_MSG(!e2e_exists(parts), "the merge job left the parts folder behind");
        }
        free(args);
    }
    e2e_rmtree(s.dir);
}

/* One array task of tiles.sbatch as Slurm runs it: job, the array's lowest and highest
 * id and how many it has, this task's id; env: more variables (TILES, PARTS_DIR) or "".
 * The stand-in sbatch in the folder records the merge job as sbatch.JOB. */
static int array_task(const Setup *s, const char *env, int job, int min, int max, int count,
                      int id, E2eRun *r)
{
    char cmd[6 * PATH_MAX], full[7 * PATH_MAX + 16];
    snprintf(cmd, sizeof cmd,
             "%s PATH=\"$PWD:$PATH\" SLURM_ARRAY_JOB_ID=%d SLURM_ARRAY_TASK_MIN=%d "
             "SLURM_ARRAY_TASK_MAX=%d SLURM_ARRAY_TASK_COUNT=%d SLURM_ARRAY_TASK_ID=%d "
             "RAYTRACER='%s' bash '%s/scripts/slurm/tiles.sbatch' scene.txt frame.tga "
             "-size %s %s -shadows -bounces 2", env, job, min, max, count, id, s->bin, s->root,
             SIZE_W, SIZE_H);
    snprintf(full, sizeof full, "cd '%s' && %s", s->dir, cmd);
    char *argv[] = {(char *)"/bin/sh", (char *)"-c", full, NULL};
    CHECK(e2e_run(argv, r));
    return r->status;
}

/* The merge job task `first` of array job `job` submitted (its --wrap command), run as
 * Slurm runs it (sh); its exit status, or -1 when none was submitted. */
static int array_merge(const Setup *s, int job, E2eRun *r)
{
    char path[PATH_MAX], name[32];
    snprintf(name, sizeof name, "sbatch.%d", job);
    char *args = e2e_read_file(e2e_join(path, sizeof path, s->dir, name), NULL);
    CHECK_MSG(args != NULL, "array job %d submitted no merge job", job);
    if (!args)
        return -1;
    char dep[64];
    snprintf(dep, sizeof dep, "--dependency=afterok:%d\n", job);
    CHECK_CONTAINS(args, dep);
    const char *wrap = strstr(args, "--wrap=");
    CHECK(wrap != NULL);
    int status = -1;
    if (wrap) {
        char merge[4096], full[4096 + PATH_MAX + 16];
        snprintf(merge, sizeof merge, "%s", wrap + 7);
        merge[strcspn(merge, "\n")] = '\0';
        snprintf(full, sizeof full, "cd '%s' && %s", s->dir, merge);
        char *argv[] = {(char *)"/bin/sh", (char *)"-c", full, NULL};
        CHECK(e2e_run(argv, r));
        status = r->status;
    }
    free(args);
    return status;
}

/* Task ids that are not one range (scripts/slurm/tiles.sbatch): with TILES the ids are
 * the tile numbers, so a frame of 4 tiles rendered by --array=0,2 and then by
 * --array=1,3 into the first job's folder (PARTS_DIR) merges into the whole render;
 * the first job's merge finds tiles 1 and 3 missing, says so and keeps the folder.
 * Without TILES such an array is refused before any tile is rendered, and so is an id
 * outside 0..TILES-1. Before, a task rendered tile (id - lowest id) of (count) tiles:
 * --array=3,7 gave task 3 the top half of a 2-band frame and task 7 raytracer's usage
 * error "-tile k n: k must be below n", and the frame could not be made. */
static void test_tiles_sbatch_array_ids(void)
{
    need("bash", "bash");
    Setup s;
    if (!setup(&s, "tilesids"))
        return;
    char fake[PATH_MAX], parts[PATH_MAX], frame[PATH_MAX], why[1024];
    e2e_join(fake, sizeof fake, s.dir, "sbatch");
    CHECK(e2e_write_file(fake, "#!/bin/sh\nprintf '%s\\n' \"$@\" > sbatch.$SLURM_ARRAY_JOB_ID\n"));
    CHECK(chmod(fake, 0755) == 0);
    e2e_join(parts, sizeof parts, s.dir, "frame.tga.parts.500");
    e2e_join(frame, sizeof frame, s.dir, "frame.tga");
    E2eRun r;
    /* Without TILES: refused, nothing rendered. */
    CHECK_INT(array_task(&s, "", 499, 0, 2, 2, 2, &r), 2);
    CHECK_CONTAINS(r.err, "are not one range");
    CHECK_CONTAINS(r.err, "TILES=N");
    e2e_run_free(&r);
    /* An id past the tiles: refused. */
    CHECK_INT(array_task(&s, "TILES=4", 499, 0, 6, 4, 6, &r), 2);
    CHECK_CONTAINS(r.err, "array task 6: out of range: TILES=4 tiles are numbered 0 to 3");
    e2e_run_free(&r);
    char stray[PATH_MAX];
    CHECK_MSG(!e2e_exists(e2e_join(stray, sizeof stray, s.dir, "frame.tga.parts.499")),
              "a refused task made its parts folder");
    /* --array=0,2 of 4 tiles (ids out of order, as Slurm may run them). */
    static const int first_ids[2] = {2, 0}, again_ids[2] = {3, 1};
    for (int i = 0; i < 2; i++) {
        CHECK_MSG(array_task(&s, "TILES=4", 500, 0, 2, 2, first_ids[i], &r) == 0,
                  "task %d of --array=0,2: %s", first_ids[i], e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
    }
    CHECK_MSG(array_merge(&s, 500, &r) != 0, "the merge of tiles 0 and 2 of 4 succeeded");
    CHECK_CONTAINS(r.err, "part1.tga: error: cannot read image:");
    e2e_run_free(&r);
    CHECK_MSG(!e2e_exists(frame), "a failed merge wrote the frame");
    CHECK_MSG(e2e_exists(parts), "a failed merge removed the parts folder");
    /* --array=1,3 into that folder: the missing tiles, then the whole frame. */
    char env[PATH_MAX + 64];
    snprintf(env, sizeof env, "TILES=4 PARTS_DIR='%s'", parts);
    for (int i = 0; i < 2; i++) {
        CHECK_MSG(array_task(&s, env, 501, 1, 3, 2, again_ids[i], &r) == 0,
                  "task %d of --array=1,3: %s", again_ids[i], e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
    }
    CHECK_MSG(array_merge(&s, 501, &r) == 0, "the merge of all 4 tiles: %s",
              e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    CHECK_MSG(same_file(frame, s.ref), "--array=0,2 then 1,3: frame differs from the whole "
              "render");
    CHECK_MSG(!e2e_exists(parts), "the merge job left the parts folder behind");
    e2e_rmtree(s.dir);
}

static void test_render_sbatch_fallback(void)
{
    need("mpirun", "openmpi-bin");
    const char *mpi = getenv("RT_MPI_BIN");
    if (!mpi || access(mpi, X_OK) != 0) {
        const char *req = getenv("RT_REQUIRE_MPI");
        if (req && strcmp(req, "1") == 0) {
            CHECK_MSG(false, "RT_REQUIRE_MPI=1 but raytracer-mpi is not built (make mpi)");
            return;
        }
        harness_skip("raytracer-mpi not built (make mpi)");
    }
    Setup s;
    if (!setup(&s, "renderfb"))
        return;
    char cmd[6 * PATH_MAX], abs_mpi[PATH_MAX];
    CHECK(e2e_abspath(mpi, abs_mpi, sizeof abs_mpi));
    snprintf(cmd, sizeof cmd,
             "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 NP=3 RAYTRACER_MPI='%s' "
             "bash '%s/scripts/slurm/render.sbatch' scene.txt frame.tga -size %s %s -shadows "
             "-bounces 2", abs_mpi, s.root, SIZE_W, SIZE_H);
    run_recipe(&s, cmd, "render.sbatch (mpirun -np 3)");
    e2e_rmtree(s.dir);
}

static const TestCase tests[] = {
    {"parallel_one_machine", test_parallel_one_machine},
    {"parallel_sshlogin_form", test_parallel_sshlogin_form},
    {"tiles_sbatch_fallback", test_tiles_sbatch_fallback},
    {"tiles_sbatch_depth_normals", test_tiles_sbatch_depth_normals},
    {"tiles_sbatch_array_mode", test_tiles_sbatch_array_mode},
    {"tiles_sbatch_array_ids", test_tiles_sbatch_array_ids},
    {"render_sbatch_fallback", test_render_sbatch_fallback},
};
RT_TEST_MAIN(tests)
