/* README.txt stays true: every command it shows (a line starting with "$ ", continued
 * by trailing backslashes) runs with exit status 0 in a temporary folder that holds
 * ./raytracer, scenes/, models/, build/tools/ and the course's files; the table of
 * contents matches the section headings; every docs/ file it names exists. The commands
 * are extracted generically, so commands added to README later are run too. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <dirent.h>
#include <unistd.h>

#include "../harness.h"
#include "e2e_util.h"

enum { MAX_COMMANDS = 256 };

typedef struct Command {
    int line;      /* 1-based line of the "$ " in README.txt */
    int end_line;  /* its last line (the same unless continued by backslashes) */
    char *text;    /* the shell command, continuation lines joined */
} Command;

static char *readme_text(void)
{
    char path[PATH_MAX];
    e2e_join(path, sizeof path, harness_root(), "README.txt");
    char *text = e2e_read_file(path, NULL);
    CHECK_MSG(text != NULL, "cannot read %s", path);
    return text;
}

/* Splits text into its "$ " commands (at most max). A line ending in a backslash
 * continues on the next line, whose leading blanks are dropped. */
static int extract_commands(const char *text, Command *out, int max)
{
    int n = 0, line = 1;
    const char *p = text;
    while (*p) {
        const char *eol = strchr(p, '\n');
        size_t len = eol ? (size_t)(eol - p) : strlen(p);
        const char *s = p;
        while (s < p + len && *s == ' ')
            s++;
        int start_line = line;
        p += len + (eol ? 1 : 0);
        line++;
        if (!(s + 2 <= p && s[0] == '$' && s[1] == ' '))
            continue;
        s += 2;
        size_t cap = 256, used = 0;
        char *cmd = malloc(cap);
        if (!cmd)
            return n;
        size_t piece = (size_t)((p - (eol ? 1 : 0)) - s);
        for (;;) {
            bool more = piece > 0 && s[piece - 1] == '\\';
            if (more)
                piece--;
            if (used + piece + 2 > cap) {
                while (used + piece + 2 > cap)
                    cap *= 2;
                char *nc = realloc(cmd, cap);
                if (!nc) {
                    free(cmd);
                    return n;
                }
                cmd = nc;
            }
            memcpy(cmd + used, s, piece);
            used += piece;
            cmd[used] = '\0';
            if (!more || !*p)
                break;
            cmd[used++] = ' ';
            cmd[used] = '\0';
            eol = strchr(p, '\n');
            len = eol ? (size_t)(eol - p) : strlen(p);
            s = p;
            while (s < p + len && *s == ' ')
                s++;
            piece = (size_t)(p + len - s);
            p += len + (eol ? 1 : 0);
            line++;
        }
        if (n < max) {
            out[n].line = start_line;
            out[n].end_line = line - 1;
            out[n].text = cmd;
            n++;
        } else {
            free(cmd);
        }
    }
    return n;
}

static void free_commands(Command *c, int n)
{
    for (int i = 0; i < n; i++)
        free(c[i].text);
}

static void test_extraction(void)
{
    static const char sample[] =
        "text\n"
        "    $ ./raytracer -input a.txt \\\n"
        "          -output b.tga\n"
        "  not $ a command\n"
        "$ echo done\n";
    Command c[4];
    int n = extract_commands(sample, c, 4);
    CHECK_INT(n, 2);
    if (n == 2) {
        CHECK_STR(c[0].text, "./raytracer -input a.txt  -output b.tga");
        CHECK_INT(c[0].line, 2);
        CHECK_STR(c[1].text, "echo done");
        CHECK_INT(c[1].line, 5);
    }
    free_commands(c, n);
}

static bool make_link(const char *target, const char *dir, const char *name)
{
    char path[PATH_MAX];
    e2e_join(path, sizeof path, dir, name);
    return symlink(target, path) == 0;
}

/* The folder the commands run in: links to the binary, the tools, the project's scenes
 * and models, and every entry of the course folder (when present). */
static bool make_workdir(char *dir, size_t size)
{
    if (!e2e_tmpdir(dir, size, "readme"))
        return false;
    char abs[PATH_MAX], path[PATH_MAX];
    const char *root = harness_root();
    bool ok = e2e_abspath(harness_bin(), abs, sizeof abs) && make_link(abs, dir, "raytracer");
    for (int i = 0; ok && i < 2; i++) {
        const char *sub = i == 0 ? "scenes" : "models";
        e2e_join(path, sizeof path, root, sub);
        ok = e2e_abspath(path, abs, sizeof abs) && make_link(abs, dir, sub);
    }
    e2e_join(path, sizeof path, dir, "build");
    ok = ok && mkdir(path, 0755) == 0;
    const char *tools = getenv("RT_TOOLS");
    char tools_buf[PATH_MAX];
    if (!tools || !*tools) {
        e2e_join(tools_buf, sizeof tools_buf, root, "build/tools");
        tools = tools_buf;
    }
    ok = ok && e2e_abspath(tools, abs, sizeof abs) && make_link(abs, path, "tools");
    const char *course = harness_course_dir();
    if (ok && course) {
        DIR *d = opendir(course);
        struct dirent *e;
        while (d && (e = readdir(d)) != NULL) {
            if (e->d_name[0] == '.')
                continue;
            e2e_join(path, sizeof path, course, e->d_name);
            if (e2e_abspath(path, abs, sizeof abs))
                ok = ok && make_link(abs, dir, e->d_name);
        }
        if (d)
            closedir(d);
    }
    return ok;
}

/* The first word of cmd ending in .txt or .obj, without a folder (the course's files
 * are named so), that names no file in dir (copied into name); false when every such
 * word names a file. */
static bool missing_input(const char *cmd, const char *dir, char *name, size_t size)
{
    const char *p = cmd;
    while (*p) {
        while (*p && isspace((unsigned char)*p))
            p++;
        const char *w = p;
        while (*p && !isspace((unsigned char)*p))
            p++;
        size_t n = (size_t)(p - w);
        if (n > 4 && n < size && !memchr(w, '/', n) &&
            (!strncmp(p - 4, ".txt", 4) || !strncmp(p - 4, ".obj", 4))) {
            char path[PATH_MAX];
            snprintf(name, size, "%.*s", (int)n, w);
            e2e_join(path, sizeof path, dir, name);
            if (!e2e_exists(path))
                return true;
        }
    }
    return false;
}

/* True when the program name (a word without a slash) is an executable file in one of
 * PATH's folders, as the shell would find it. */
static bool on_path(const char *name)
{
    const char *path = getenv("PATH");
    if (!path)
        path = "/usr/bin:/bin";
    char file[PATH_MAX];
    for (const char *p = path;;) {
        size_t n = strcspn(p, ":");
        snprintf(file, sizeof file, "%.*s/%s", (int)(n ? n : 1), n ? p : ".", name);
        if (access(file, X_OK) == 0)
            return true;
        if (!p[n])
            return false;
        p += n + 1;
    }
}

/* The first program of cmd that the shell would look up in PATH and not find (copied
 * into name): the first word of each stage of a pipeline, after any NAME=value. A word with a slash
 * (./raytracer, build/tools/imgdiff) is the project's own and never counts as missing:
 * a wrong path in README must fail, not be skipped. */
static bool missing_program(const char *cmd, char *name, size_t size)
{
    for (const char *p = cmd; p;) {
        p += strspn(p, " ");
        size_t n = strcspn(p, " |");
        /* Environment assignments (NAME=value) come before the program. */
        while (n > 0 && memchr(p, '=', n)) {
            p += n;
            p += strspn(p, " ");
            n = strcspn(p, " |");
        }
        if (n > 0 && n < size && !memchr(p, '/', n)) {
            snprintf(name, size, "%.*s", (int)n, p);
            if (!on_path(name))
                return true;
        }
        p = strchr(p, '|');
        if (p)
            p++;
    }
    return false;
}

typedef struct Tally {
    int ran, skipped, failed;
} Tally;

/* Runs cmds[0..n) with /bin/sh in the current folder and counts them. A command is
 * skipped, with the reason printed, when its input is the course's and there is no
 * course folder, when it names a program that is not installed (GNU parallel is an
 * optional package: README section 1), or when this build leaves out the feature it
 * uses; and so is every command of the same block after it (commands on consecutive
 * lines: the merge after the renders of its parts), since it uses what the skipped one
 * would have made. With require_tools (RT_REQUIRE_TOOLS=1, as CI runs) a missing
 * program is a failure instead. A failure is printed and counted; report says whether
 * it is also a failed check of the test. */
static void run_commands(const char *src, const Command *cmds, int n, const char *dir,
                         bool have_course, bool require_tools, bool report, Tally *t)
{
    int skipped_at = 0, block_end = -1;
    for (int i = 0; i < n; i++) {
        char name[256];
        bool same_block = cmds[i].line == block_end + 1;
        block_end = cmds[i].end_line;
        if (skipped_at && same_block) {
            printf("   %s:%d: skipped: follows the skipped command of line %d\n",
                   src, cmds[i].line, skipped_at);
            t->skipped++;
            continue;
        }
        skipped_at = 0;
        if (!have_course && missing_input(cmds[i].text, dir, name, sizeof name)) {
            printf("   %s:%d: skipped: %s is not there (no course folder)\n",
                   src, cmds[i].line, name);
            skipped_at = cmds[i].line;
            t->skipped++;
            continue;
        }
        if (missing_program(cmds[i].text, name, sizeof name)) {
            if (require_tools) {
                printf("   %s:%d: %s is not installed (RT_REQUIRE_TOOLS=1)\n",
                       src, cmds[i].line, name);
                CHECK_MSG(!report, "%s:%d: RT_REQUIRE_TOOLS=1 but %s is not "
                          "installed", src, cmds[i].line, name);
                t->failed++;
            } else {
                printf("   %s:%d: skipped: %s is not installed\n", src, cmds[i].line,
                       name);
                t->skipped++;
            }
            skipped_at = cmds[i].line;
            continue;
        }
        char *argv[] = {(char *)"/bin/sh", (char *)"-c", cmds[i].text, NULL};
        E2eRun r;
        CHECK(e2e_run(argv, &r));
        /* A feature left out of this build says so and exits 2: not a README bug. */
        if (r.status == 2 && strstr(r.err, "not built in")) {
            printf("   %s:%d: skipped: %s", src, cmds[i].line, r.err);
            skipped_at = cmds[i].line;
            t->skipped++;
        } else if (r.status != 0) {
            char why[512];
            e2e_describe(&r, why, sizeof why);
            printf("   %s:%d: '%s': %s\n", src, cmds[i].line, cmds[i].text, why);
            CHECK_MSG(!report, "%s:%d: '%s': %s", src, cmds[i].line, cmds[i].text, why);
            t->failed++;
        } else {
            t->ran++;
        }
        e2e_run_free(&r);
    }
}

static bool require_tools(void)
{
    const char *req = getenv("RT_REQUIRE_TOOLS");
    return req && strcmp(req, "1") == 0;
}

static void test_commands_run(void)
{
    char *text = readme_text();
    if (!text)
        return;
    Command cmds[MAX_COMMANDS];
    int n = extract_commands(text, cmds, MAX_COMMANDS);
    free(text);
    /* The quick start alone shows three; fewer means the extraction broke. */
    CHECK_MSG(n >= 3, "only %d commands found in README.txt", n);
    char dir[PATH_MAX];
    if (!make_workdir(dir, sizeof dir)) {
        CHECK_MSG(false, "cannot set up the folder for README's commands");
        free_commands(cmds, n);
        return;
    }
    char cwd[PATH_MAX];
    CHECK(getcwd(cwd, sizeof cwd) != NULL);
    const char *old_path = getenv("PATH");
    char path_env[PATH_MAX * 2];
    snprintf(path_env, sizeof path_env, "%s:%s", dir, old_path ? old_path : "/usr/bin:/bin");
    setenv("PATH", path_env, 1);
    Tally t = {0, 0, 0};
    /* Asked before the chdir: the default course folder is relative to the project
     * ("./../shared/course"), and from the temporary folder it would name another. */
    bool have_course = harness_course_dir() != NULL;
    if (chdir(dir) == 0) {
        run_commands("README.txt", cmds, n, dir, have_course, require_tools(), true, &t);
        CHECK(chdir(cwd) == 0);
    }
    printf("   %d README commands run, %d skipped\n", t.ran, t.skipped);
    CHECK(t.ran > 0);
    e2e_rmtree(dir);
    free_commands(cmds, n);
}

/* A README command whose program is not installed is skipped with the commands of its
 * block after it, not failed (make test on a machine with only README's requirements);
 * the next block runs; with RT_REQUIRE_TOOLS=1 the missing program is a failure. Before
 * this, README's GNU parallel recipe failed make test wherever parallel was not
 * installed, and the merge after it failed for want of the parts. */
static void test_missing_program_skips_block(void)
{
    static const char sample[] =
        "    $ rt-readme-test-no-such-program -x ::: 0 1\n"
        "    $ false\n"
        "\n"
        "    $ true | RT_X=1 rt-readme-test-no-such-program-either\n"
        "\n"
        "    $ ./rt-readme-test-no-such-file\n"
        "\n"
        "    $ true\n";
    Command c[8];
    int n = extract_commands(sample, c, 8);
    CHECK_INT(n, 5);
    char dir[PATH_MAX], cwd[PATH_MAX];
    if (n != 5 || !e2e_tmpdir(dir, sizeof dir, "readme_skip") || !getcwd(cwd, sizeof cwd)) {
        free_commands(c, n);
        return;
    }
    if (chdir(dir) == 0) {
        Tally t = {0, 0, 0};
        run_commands("sample", c, n, dir, true, false, false, &t);
        /* The first two and the pipeline skipped; the missing ./ file is README's own
         * mistake and fails; true runs. */
        CHECK_INT(t.skipped, 3);
        CHECK_INT(t.failed, 1);
        CHECK_INT(t.ran, 1);
        Tally req = {0, 0, 0};
        run_commands("sample", c, n, dir, true, true, false, &req);
        CHECK_INT(req.failed, 3);
        CHECK_INT(req.skipped, 1);
        CHECK_INT(req.ran, 1);
        CHECK(chdir(cwd) == 0);
    }
    e2e_rmtree(dir);
    free_commands(c, n);
}

/* Each entry "N. Title" of the Contents is a heading "N. Title" underlined by dashes,
 * in the same order. */
static void test_contents_match_sections(void)
{
    char *text = readme_text();
    if (!text)
        return;
    const char *toc = strstr(text, "\nContents\n");
    CHECK_MSG(toc != NULL, "README.txt has no Contents");
    int entries = 0;
    const char *search_from = toc ? strstr(toc + 1, "\n\n") : NULL;
    for (const char *p = toc ? toc + 10 : NULL; p && *p && *p != '\n';) {
        const char *eol = strchr(p, '\n');
        size_t len = eol ? (size_t)(eol - p) : strlen(p);
        const char *s = p;
        while (s < p + len && *s == ' ')
            s++;
        char heading[160];
        snprintf(heading, sizeof heading, "\n%.*s\n-", (int)(p + len - s), s);
        const char *at = search_from ? strstr(search_from, heading) : NULL;
        CHECK_MSG(at != NULL, "Contents entry '%.*s' has no underlined heading after the "
                  "previous one", (int)(p + len - s), s);
        if (at)
            search_from = at + 1;
        entries++;
        p = eol ? eol + 1 : p + len;
    }
    CHECK(entries >= 5);
    free(text);
}

static void test_docs_links_exist(void)
{
    char *text = readme_text();
    if (!text)
        return;
    int links = 0;
    for (const char *p = strstr(text, "docs/"); p; p = strstr(p + 1, "docs/")) {
        size_t n = 5;
        while (isalnum((unsigned char)p[n]) || p[n] == '-' || p[n] == '_' || p[n] == '.')
            n++;
        while (n > 5 && p[n - 1] == '.')
            n--; /* a full stop ending the sentence */
        if (n == 5)
            continue; /* the folder itself */
        char rel[256], path[PATH_MAX];
        snprintf(rel, sizeof rel, "%.*s", (int)n, p);
        e2e_join(path, sizeof path, harness_root(), rel);
        CHECK_MSG(e2e_exists(path), "README.txt names %s, which does not exist", rel);
        links++;
    }
    CHECK(links > 0);
    free(text);
}

/* The -stats example of section 6 is what the program prints: every line of the block
 * in README.txt (indented by four) but the two that depend on time is a line of the
 * real output of the command above it. */
static void test_stats_example_matches(void)
{
    char *text = readme_text();
    if (!text)
        return;
    const char *head = strstr(text, "\n    RAY TRACING STATISTICS\n");
    CHECK_MSG(head != NULL, "README.txt has no -stats example block");
    char scene[PATH_MAX];
    e2e_join(scene, sizeof scene, harness_root(), "scenes/feat_sphere_grid.txt");
    const char *args[] = {"-input", scene, "-size", "200", "200", "-shadows", "-grid", "10",
                          "10", "10", "-stats", NULL};
    E2eRun r;
    if (head && e2e_run_bin(harness_bin(), args, &r)) {
        CHECK_INT(r.status, 0);
        int lines = 0;
        for (const char *p = head + 1; strncmp(p, "    ", 4) == 0;) {
            const char *eol = strchr(p, '\n');
            if (!eol)
                break;
            char line[256];
            snprintf(line, sizeof line, "%.*s\n", (int)(eol - p - 4), p + 4);
            if (!strstr(line, "total time") && !strstr(line, "rays per second")) {
                CHECK_MSG(strstr(r.out, line) != NULL, "README's -stats line '%.*s' is not "
                          "in the output:\n%s", (int)strlen(line) - 1, line, r.out);
                lines++;
            }
            p = eol + 1;
            if (line[0] == '*')
                break;
        }
        CHECK_MSG(lines >= 10, "only %d lines of the -stats example compared", lines);
        e2e_run_free(&r);
    }
    free(text);
}

/* Section 11 lists every document of docs/: a new one (docs/distributed.md was left
 * out) shows up in the list, not only where another section mentions it. */
static void test_docs_listed(void)
{
    char *text = readme_text();
    if (!text)
        return;
    const char *list = strstr(text, "\n11. More documentation (docs/)\n-");
    CHECK_MSG(list != NULL, "README.txt has no section 11, More documentation (docs/)");
    const char *end = list ? strstr(list + 1, "\n12. ") : NULL;
    char dir[PATH_MAX];
    e2e_join(dir, sizeof dir, harness_root(), "docs");
    DIR *d = opendir(dir);
    CHECK_MSG(d != NULL, "cannot open %s", dir);
    int docs = 0;
    for (struct dirent *e; d && list && end && (e = readdir(d)) != NULL;) {
        size_t len = strlen(e->d_name);
        if (len < 4 || strcmp(e->d_name + len - 3, ".md") != 0)
            continue;
        /* An entry is the line "  docs/NAME.md" followed by its description. */
        char entry[300];
        snprintf(entry, sizeof entry, "\n  docs/%s ", e->d_name);
        const char *at = strstr(list, entry);
        CHECK_MSG(at != NULL && at < end, "docs/%s is not listed in README.txt section 11",
                  e->d_name);
        docs++;
    }
    if (d)
        closedir(d);
    CHECK(docs >= 10);
    free(text);
}

/* The usage errors section 5 shows are the program's own lines, word for word: each
 * command line below gives one line on stderr, and README.txt shows it (indented by
 * four). The scene is never opened: usage is checked first. */
static void test_usage_examples_match(void)
{
    char *text = readme_text();
    if (!text)
        return;
    static const char *const runs[][9] = {
        {"-input", "s.txt", "-output", "a.tga", "-shadow", NULL},
        {"-input", "s.txt", "-output", "a.tga", "-size", "200", "200", "300", NULL},
        {"-input", "s.txt", "-output", "a.tga", "-size", "200", "0", NULL},
        {"-input", "s.txt", "-output", "a.tga", "-size", "200x150", NULL},
        {"-input", "s.txt", "-output", "-size", "200", "200", NULL},
        {"-input", "s.txt", "shadows", "-output", "a.tga", NULL},
    };
    for (size_t i = 0; i < sizeof runs / sizeof runs[0]; i++) {
        E2eRun r;
        if (!e2e_run_bin(harness_bin(), runs[i], &r))
            continue;
        CHECK_INT(r.status, 2);
        const char *nl = strchr(r.err, '\n');
        CHECK_MSG(nl && !nl[1], "not one line on stderr:\n%s", r.err);
        char line[600];
        snprintf(line, sizeof line, "\n    %s", r.err);
        CHECK_MSG(strstr(text, line) != NULL, "README.txt section 5 does not show the "
                  "program's line:\n%s", r.err);
        e2e_run_free(&r);
    }
    free(text);
}

/* The name of a group heading: up to " (" or the line's end ("Antialiasing (section
 * 9)" and -h's "Antialiasing (one centred sample ...)" are both "Antialiasing"). */
static size_t group_name_len(const char *h)
{
    size_t len = strcspn(h, "\n");
    const char *paren = strstr(h, " (");
    return paren && (size_t)(paren - h) < len ? (size_t)(paren - h) : len;
}

/* Where section 3 (from sec to end) gives option name its entry: a line that starts
 * with two blanks and the name, or names it in a list of options at a line's start
 * ("  -uniform_samples N, -jittered_samples N,", "  raytracer -merge OUT"); else its
 * first mention as a whole word. NULL when there is none. */
static const char *options_entry(const char *sec, const char *end, const char *name)
{
    size_t n = strlen(name);
    for (const char *l = sec; l && l < end; l = strchr(l + 1, '\n')) {
        const char *p = l + 1;
        if (strncmp(p, "  -", 3) && strncmp(p, "  raytracer -", 13))
            continue;
        p += 2;
        if (!strncmp(p, "raytracer ", 10))
            p += 10;
        for (;;) {
            if (!strncmp(p, name, n) && (p[n] == ' ' || p[n] == ',' || p[n] == '\n'))
                return p;
            /* the next name of a list: after the name and its values, ", -" */
            const char *eol = strchr(p, '\n');
            const char *comma = strstr(p, ", -");
            const char *gap = strstr(p, "  ");
            if (!comma || (eol && comma > eol) || (gap && gap < comma))
                break;
            p = comma + 2;
        }
    }
    for (const char *p = strstr(sec, name); p && p < end; p = strstr(p + 1, name)) {
        char before = p[-1], after = p[n];
        if (before != '-' && before != '_' && !isalnum((unsigned char)before) &&
            after != '_' && !isalnum((unsigned char)after))
            return p;
    }
    return NULL;
}

/* Section 3 lists every option of raytracer -h under a group heading of the same name
 * as -h's ("Speed" once held -h's "Acceleration", and -noise_cutoff stood under
 * Antialiasing there and under Shading in -h and the man page). A heading is a line at
 * the margin followed by an option's line. */
static void test_options_grouped_as_help(void)
{
    char *text = readme_text();
    if (!text)
        return;
    const char *sec = strstr(text, "\n3. Options\n-");
    const char *end = sec ? strstr(sec, "\n4. ") : NULL;
    CHECK_MSG(sec && end, "README.txt has no section 3, Options, before section 4");
    const char *args[] = {"-h", NULL};
    E2eRun r;
    if (!sec || !end || !e2e_run_bin(harness_bin(), args, &r)) {
        free(text);
        return;
    }
    CHECK_INT(r.status, 0);
    const char *group = NULL; /* -h's group of the lines that follow */
    int checked = 0;
    for (const char *line = r.out; line && *line;) {
        const char *eol = strchr(line, '\n');
        if (!strncmp(line, "Exit status", 11))
            break;
        if (line[0] != ' ' && line[0] != '\n' && strncmp(line, "usage:", 6)) {
            group = line;
        } else if (group && !strncmp(line, "  -", 3)) {
            /* each name of the line ("  -h, --help" has two) */
            for (const char *p = line + 2; *p == '-';) {
                char name[64];
                size_t nl = strcspn(p, " ,\n");
                snprintf(name, sizeof name, "%.*s", (int)nl, p);
                const char *at = options_entry(sec, end, name);
                CHECK_MSG(at != NULL, "README.txt section 3 does not list %s", name);
                /* the heading above it: the last margin line followed by "  -" */
                const char *heading = NULL;
                for (const char *h = sec; at && h && h < at; h = strchr(h + 1, '\n')) {
                    const char *next = strchr(h + 1, '\n');
                    if (h[1] != ' ' && h[1] != '\n' && next && next < at &&
                        (!strncmp(next + 1, "  -", 3) || !strncmp(next + 1, "  raytracer -", 13)))
                        heading = h + 1;
                }
                size_t gl = group_name_len(group), hl = heading ? group_name_len(heading) : 0;
                CHECK_MSG(!at || (heading && gl == hl && !strncmp(group, heading, gl)),
                          "README.txt section 3 lists %s under '%.*s', raytracer -h under "
                          "'%.*s'", name, (int)hl, heading ? heading : "", (int)gl, group);
                checked++;
                p += nl;
                if (strncmp(p, ", ", 2))
                    break;
                p += 2;
            }
        }
        line = eol ? eol + 1 : NULL;
    }
    CHECK_MSG(checked > 40, "only %d options of -h were looked up", checked);
    e2e_run_free(&r);
    free(text);
}

static const TestCase tests[] = {
    {"readme_command_extraction", test_extraction},
    {"readme_commands_run", test_commands_run},
    {"readme_missing_program_skips_block", test_missing_program_skips_block},
    {"readme_contents_match_sections", test_contents_match_sections},
    {"readme_docs_links_exist", test_docs_links_exist},
    {"readme_stats_example_matches", test_stats_example_matches},
    {"readme_docs_listed", test_docs_listed},
    {"readme_usage_examples_match", test_usage_examples_match},
    {"readme_options_grouped_as_help", test_options_grouped_as_help},
};

RT_TEST_MAIN(tests)
