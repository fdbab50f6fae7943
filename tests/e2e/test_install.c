/* make install / make uninstall into a DESTDIR: the binary (the one under test, byte
 * for byte), the manual page (formatted by man -l and groff -ww without a warning, and
 * naming every option of raytracer -h) and the bash completion (sourced in bash: -sha
 * completes to -shadows and -shade_back, -input offers scenes, -output images, every
 * option of -h is offered; loaded from DESTDIR by bash-completion's own loader).
 * A missing tool (man, groff, bash-completion) skips its test with the reason printed,
 * unless RT_REQUIRE_TOOLS=1 (CI), which makes it a failure. */
#define _POSIX_C_SOURCE 200809L
#include "../harness.h"
#include "e2e_util.h"

/* A skip, or a failure when CI requires every tool. */
static void missing_tool(const char *why)
{
    const char *req = getenv("RT_REQUIRE_TOOLS");
    if (req && strcmp(req, "1") == 0) {
        harness_fail(__FILE__, __LINE__, "RT_REQUIRE_TOOLS=1 but %s", why);
        fflush(stdout);
        _exit(1);
    }
    harness_skip(why);
}

/* The full path of program on PATH into buf; false when it is not there. */
static bool find_program(const char *program, char *buf, size_t size)
{
    const char *path = getenv("PATH");
    char copy[4096];
    snprintf(copy, sizeof copy, "%s", path ? path : "/usr/bin:/bin");
    for (char *d = strtok(copy, ":"); d; d = strtok(NULL, ":")) {
        e2e_join(buf, size, d, program);
        if (access(buf, X_OK) == 0)
            return true;
    }
    return false;
}

static void need_program(const char *program, const char *package, char *buf, size_t size)
{
    if (!find_program(program, buf, size)) {
        char why[256];
        snprintf(why, sizeof why, "%s not found (apt-get install %s)", program, package);
        missing_tool(why);
    }
}

/* The nested make gets the outer make's variables (BUILD, SAN, CC, ... after "--" in
 * MAKEFLAGS), so it installs the binary under test without rebuilding; the outer job
 * server's descriptors are not passed on. */
static void nested_make_env(void)
{
    const char *mf = getenv("MAKEFLAGS");
    const char *vars = mf ? strstr(mf, " -- ") : NULL;
    if (vars)
        setenv("MAKEFLAGS", vars, 1);
    else
        unsetenv("MAKEFLAGS");
    unsetenv("MFLAGS");
}

/* Runs make TARGET DESTDIR=dest PREFIX=prefix in the project's root. */
static bool run_make_prefix(const char *target, const char *dest, const char *prefix,
                            E2eRun *r)
{
    char make[PATH_MAX], destvar[PATH_MAX + 16], prefixvar[PATH_MAX + 16];
    if (!find_program("make", make, sizeof make)) {
        CHECK_MSG(false, "make not found");
        return false;
    }
    nested_make_env();
    snprintf(destvar, sizeof destvar, "DESTDIR=%s", dest);
    snprintf(prefixvar, sizeof prefixvar, "PREFIX=%s", prefix);
    char *argv[] = {make, (char *)"--no-print-directory", (char *)"-C", (char *)harness_root(),
                    (char *)target, destvar, prefixvar, NULL};
    if (!e2e_run(argv, r))
        return false;
    char why[512];
    CHECK_MSG(r->status == 0, "make %s: %s; stdout: %.300s", target,
              e2e_describe(r, why, sizeof why), r->out);
    return r->status == 0;
}

static bool run_make(const char *target, const char *dest, E2eRun *r)
{
    return run_make_prefix(target, dest, "/usr/local", r);
}

/* Installs into a fresh DESTDIR (dest); false on failure (already reported). */
static bool install_to(char *dest, size_t size)
{
    if (!e2e_tmpdir(dest, size, "install")) {
        CHECK_MSG(false, "cannot make a temporary folder");
        return false;
    }
    E2eRun r;
    bool ok = run_make("install", dest, &r);
    e2e_run_free(&r);
    return ok;
}

static const char *const k_installed[] = {
    "usr/local/bin/raytracer",
    "usr/local/share/man/man1/raytracer.1",
    "usr/local/share/bash-completion/completions/raytracer",
    "usr/local/share/doc/raytracer/README.txt",
};

static bool same_bytes(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *da = e2e_read_file(a, &la), *db = e2e_read_file(b, &lb);
    bool same = da && db && la == lb && memcmp(da, db, la) == 0;
    free(da);
    free(db);
    return same;
}

static void test_install_uninstall(void)
{
    char dest[PATH_MAX], path[PATH_MAX];
    if (!install_to(dest, sizeof dest))
        return;
    for (size_t i = 0; i < sizeof k_installed / sizeof k_installed[0]; i++) {
        e2e_join(path, sizeof path, dest, k_installed[i]);
        CHECK_MSG(e2e_exists(path), "make install did not install %s", k_installed[i]);
    }
    e2e_join(path, sizeof path, dest, k_installed[0]);
    CHECK_MSG(access(path, X_OK) == 0, "%s is not executable", path);
    CHECK_MSG(same_bytes(path, harness_bin()), "the installed binary is not %s",
              harness_bin());
    const char *args[] = {"--version", NULL};
    E2eRun r;
    CHECK(e2e_run_bin(path, args, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.out, "raytracer ");
    e2e_run_free(&r);
    /* raytracer-mpi goes with it exactly when make mpi built it. */
    const char *mpi = getenv("RT_MPI_BIN");
    bool have_mpi = mpi && *mpi && access(mpi, X_OK) == 0;
    e2e_join(path, sizeof path, dest, "usr/local/bin/raytracer-mpi");
    CHECK_MSG(e2e_exists(path) == have_mpi, "raytracer-mpi %s installed, %s built",
              e2e_exists(path) ? "is" : "is not", have_mpi ? "is" : "is not");
    /* and with it its manual page: a link to raytracer.1 ("man raytracer-mpi") */
    e2e_join(path, sizeof path, dest, "usr/local/share/man/man1/raytracer-mpi.1");
    char target[PATH_MAX] = "";
    ssize_t tn = readlink(path, target, sizeof target - 1);
    target[tn > 0 ? tn : 0] = '\0';
    if (have_mpi)
        CHECK_MSG(tn > 0 && strcmp(target, "raytracer.1") == 0,
                  "raytracer-mpi.1 is not a link to raytracer.1 (%s)", tn > 0 ? target : "missing");
    else
        CHECK_MSG(tn < 0 && !e2e_exists(path), "raytracer-mpi.1 installed without raytracer-mpi");

    /* The user's guide the manual page names is installed, and the page names it where
     * it is (an installed page has no source tree to point into). */
    char readme[PATH_MAX];
    e2e_join(path, sizeof path, dest, "usr/local/share/doc/raytracer/README.txt");
    e2e_join(readme, sizeof readme, harness_root(), "README.txt");
    CHECK_MSG(same_bytes(path, readme), "the installed README.txt is not the tree's");
    e2e_join(path, sizeof path, dest, "usr/local/share/man/man1/raytracer.1");
    char *page = e2e_read_file(path, NULL);
    CHECK_MSG(page && strstr(page, "\n.SH \"SEE ALSO\"") &&
                  strstr(strstr(page, "\n.SH \"SEE ALSO\""),
                         "\n.I /usr/local/share/doc/raytracer/README.txt\n"),
              "the manual page's SEE ALSO does not name the installed README.txt");
    CHECK_MSG(page && !strstr(page, "README.txt and docs/ in the source tree"),
              "the manual page's SEE ALSO points into the source tree");
    free(page);

    if (run_make("uninstall", dest, &r)) {
        for (size_t i = 0; i < sizeof k_installed / sizeof k_installed[0]; i++) {
            e2e_join(path, sizeof path, dest, k_installed[i]);
            CHECK_MSG(!e2e_exists(path), "make uninstall left %s", k_installed[i]);
        }
        e2e_join(path, sizeof path, dest, "usr/local/bin/raytracer-mpi");
        CHECK_MSG(!e2e_exists(path), "make uninstall left raytracer-mpi");
        e2e_join(path, sizeof path, dest, "usr/local/share/man/man1/raytracer-mpi.1");
        struct stat lst;
        CHECK_MSG(lstat(path, &lst) != 0, "make uninstall left raytracer-mpi.1");
        /* The project's own folder goes with its file; its parent is shared. */
        e2e_join(path, sizeof path, dest, "usr/local/share/doc/raytracer");
        CHECK_MSG(!e2e_exists(path), "make uninstall left share/doc/raytracer");
        /* Nothing of ours is left, and the folders install made stay: each is shared
         * (README.txt, Installing), none is the project's own. */
        static const char *const shared[] = {"usr/local/bin", "usr/local/share/man/man1",
                                             "usr/local/share/bash-completion/completions",
                                             "usr/local/share/doc"};
        for (size_t i = 0; i < sizeof shared / sizeof shared[0]; i++) {
            e2e_join(path, sizeof path, dest, shared[i]);
            int n = e2e_count_entries(path);
            CHECK_MSG(n == 0, "after make uninstall %s %s", shared[i],
                      n < 0 ? "is gone (a shared folder)" : "still holds files");
        }
    }
    e2e_run_free(&r);
    e2e_rmtree(dest);
}

/* Another PREFIX (or DOCDIR): the README goes under it, and the installed manual page
 * names it there, not at the default's /usr/local. The PREFIX has an '&', which the
 * shell would take as "run in the background" in an unquoted recipe line (make install
 * printed its INSTALL line that way and failed) and sed as "the match" in the page's
 * substitution. */
static void test_install_prefix_doc(void)
{
    char dest[PATH_MAX], path[PATH_MAX];
    if (!e2e_tmpdir(dest, sizeof dest, "install")) {
        CHECK_MSG(false, "cannot make a temporary folder");
        return;
    }
    E2eRun r;
    memset(&r, 0, sizeof r);
    if (run_make_prefix("install", dest, "/opt/r&t", &r)) {
        e2e_join(path, sizeof path, dest, "opt/r&t/share/doc/raytracer/README.txt");
        CHECK_MSG(e2e_exists(path), "make install PREFIX=/opt/r&t did not install %s", path);
        e2e_join(path, sizeof path, dest, "opt/r&t/share/man/man1/raytracer.1");
        char *page = e2e_read_file(path, NULL);
        CHECK_MSG(page && strstr(page, "\n.I /opt/r&t/share/doc/raytracer/README.txt\n"),
                  "the manual page installed with PREFIX=/opt/r&t does not name its README");
        CHECK_MSG(page && !strstr(page, "/usr/local/share/doc"),
                  "the manual page installed with PREFIX=/opt/r&t names /usr/local's README");
        free(page);
        e2e_run_free(&r);
        if (run_make_prefix("uninstall", dest, "/opt/r&t", &r)) {
            e2e_join(path, sizeof path, dest, "opt/r&t/share/doc/raytracer");
            CHECK_MSG(!e2e_exists(path), "make uninstall left %s", path);
        }
    }
    e2e_run_free(&r);
    e2e_rmtree(dest);
}

/* The option names of raytracer -h (lines "  -name ..."; "-h, --help" gives two), each
 * as a separate malloc'd string; returns how many. */
static int help_options(char **names, int max)
{
    const char *args[] = {"-h", NULL};
    E2eRun r;
    int n = 0;
    if (!e2e_run_bin(harness_bin(), args, &r) || r.status != 0) {
        CHECK_MSG(false, "raytracer -h failed");
        e2e_run_free(&r);
        return 0;
    }
    for (char *line = r.out; line && *line;) {
        char *eol = strchr(line, '\n');
        if (eol)
            *eol = '\0';
        if (!strncmp(line, "  -", 3)) {
            char *p = line + 2;
            while (*p == '-' && n < max) {
                size_t len = strcspn(p, " ,");
                names[n] = strndup(p, len);
                bool dup = false;
                for (int k = 0; k < n && !dup; k++)
                    dup = !strcmp(names[k], names[n]);
                if (dup)
                    free(names[n]);
                else
                    n++;
                p += len;
                if (!strncmp(p, ", ", 2))
                    p += 2;
                else
                    break;
            }
        }
        line = eol ? eol + 1 : NULL;
    }
    e2e_run_free(&r);
    return n;
}

/* True when text holds word as a whole option name (not followed by a name
 * character: -grid is not found in -grid_x alone). */
static bool has_option(const char *text, const char *word)
{
    size_t n = strlen(word);
    for (const char *p = strstr(text, word); p; p = strstr(p + 1, word)) {
        char next = p[n];
        bool before_ok = p == text || !(p[-1] == '-' || p[-1] == '_' ||
                                        (p[-1] >= 'a' && p[-1] <= 'z'));
        if (before_ok && !(next == '_' || next == '-' || (next >= 'a' && next <= 'z')))
            return true;
    }
    return false;
}

/* The length of a group heading's name: up to " (" (-h's "Antialiasing (one centred
 * sample ...)" is the man page's "Antialiasing"). */
static size_t heading_name_len(const char *h)
{
    const char *paren = strstr(h, " (");
    const char *eol = strchr(h, '\n');
    size_t len = eol ? (size_t)(eol - h) : strlen(h);
    return paren && (size_t)(paren - h) < len ? (size_t)(paren - h) : len;
}

/* Where man's text (formatted at MANWIDTH 100) starts the entry of option name under
 * OPTIONS: a line of 7 blanks, then the name, then a blank, a comma or the line's end;
 * NULL when there is none. */
static const char *man_entry(const char *options, const char *name)
{
    char pat[80];
    snprintf(pat, sizeof pat, "\n       %s", name);
    size_t n = strlen(pat);
    for (const char *p = strstr(options, pat); p; p = strstr(p + 1, pat))
        if (p[n] == ' ' || p[n] == ',' || p[n] == '\n')
            return p;
    return NULL;
}

/* Every option of raytracer -h is documented in the man page's subsection of the same
 * name as its -h group (the man page once listed the preview's options under
 * "Splitting a render", with no heading of their own). man is man -l's text. */
/* raytracer -h into r (freed by the caller); false, said, when it fails. */
static bool run_help(E2eRun *r)
{
    const char *args[] = {"-h", NULL};
    if (e2e_run_bin(harness_bin(), args, r) && r->status == 0)
        return true;
    CHECK_MSG(false, "raytracer -h failed");
    e2e_run_free(r);
    return false;
}

static void check_man_groups(const char *man)
{
    const char *options = strstr(man, "\nOPTIONS\n");
    CHECK_MSG(options != NULL, "the manual page has no OPTIONS section");
    if (!options)
        return;
    E2eRun r;
    if (!run_help(&r))
        return;
    const char *heading = NULL; /* the -h group of the lines that follow */
    int checked = 0;
    for (const char *line = r.out; *line;) {
        const char *eol = strchr(line, '\n');
        size_t len = eol ? (size_t)(eol - line) : strlen(line);
        if (!strncmp(line, "Exit status", 11))
            break; /* the last paragraph, at the margin too */
        if (len > 0 && line[0] != ' ' && strncmp(line, "usage:", 6)) {
            heading = line; /* a group heading: a line at the margin */
        } else if (heading && !strncmp(line, "  -", 3) && len > 3) {
            char name[64];
            size_t nl = strcspn(line + 2, " ,\n");
            snprintf(name, sizeof name, "%.*s", (int)nl, line + 2);
            size_t hl = heading_name_len(heading);
            char sub[128];
            snprintf(sub, sizeof sub, "\n   %.*s", (int)hl, heading);
            const char *at = strstr(options, sub);
            const char *entry = man_entry(options, name);
            CHECK_MSG(at != NULL, "the manual page has no subsection '%.*s' (-h's group of %s)",
                      (int)hl, heading, name);
            CHECK_MSG(entry != NULL, "the manual page has no entry for %s", name);
            /* and names its values as -h does ("-tessellation th ph" was "theta phi"
             * there, "-gui_keys \"keys\"" was "script"): the option and its values are
             * what -h shows before its description (two blanks), and the entry's line
             * in the man page starts with exactly that */
            const char *spec = line + 2, *desc = strstr(spec, "  ");
            size_t sl = desc && desc < line + len ? (size_t)(desc - spec) : len - 2;
            char want[96];
            snprintf(want, sizeof want, "\n       %.*s", (int)sl, spec);
            bool named = false;
            size_t wl = strlen(want);
            for (const char *q = strstr(options, want); q && !named; q = strstr(q + 1, want))
                named = q[wl] == '\n' || q[wl] == ' ';
            CHECK_MSG(named, "the manual page has no entry '%.*s' as -h writes it", (int)sl,
                      spec);
            if (at && entry) {
                /* the next subsection (3 blanks and a letter) or section (a letter) */
                const char *next = NULL;
                for (const char *q = strchr(at + 1, '\n'); q && !next; q = strchr(q + 1, '\n'))
                    if ((q[1] != ' ' && q[1] != '\n') ||
                        (!strncmp(q + 1, "   ", 3) && q[4] != ' ' && q[4] != '\n'))
                        next = q;
                CHECK_MSG(entry > at && (!next || entry < next),
                          "the manual page documents %s outside its subsection '%.*s'", name,
                          (int)hl, heading);
                checked++;
            }
        }
        if (!eol)
            break;
        line = eol + 1;
    }
    CHECK_MSG(checked > 40, "only %d options of -h were found in groups", checked);
    e2e_run_free(&r);
}

/* True when text[0, len) holds num as a whole number: not part of a longer one ("16" is
 * not found in "160" nor in "1.16"). */
static bool has_number(const char *text, size_t len, const char *num)
{
    size_t n = strlen(num);
    for (size_t i = 0; i + n <= len; i++) {
        if (strncmp(text + i, num, n))
            continue;
        bool before = i > 0 && ((text[i - 1] >= '0' && text[i - 1] <= '9') ||
                                text[i - 1] == '.');
        char c = i + n < len ? text[i + n] : ' ';
        char c2 = i + n + 1 < len ? text[i + n + 1] : ' ';
        bool after = (c >= '0' && c <= '9') || (c == '.' && c2 >= '0' && c2 <= '9');
        if (!before && !after)
            return true;
    }
    return false;
}

/* The man page's entry of option name (its text up to the next entry, subsection or
 * section); *len its length, NULL when there is none. */
static const char *man_entry_text(const char *options, const char *name, size_t *len)
{
    const char *at = man_entry(options, name);
    if (!at)
        return NULL;
    const char *end = strchr(at + 1, '\n');
    while (end) {
        const char *l = end + 1;
        size_t blanks = strspn(l, " ");
        if (l[blanks] != '\n' && l[blanks] != '\0' && (blanks < 7 || (blanks == 7 && l[7] == '-')))
            break;
        end = strchr(l, '\n');
    }
    *len = end ? (size_t)(end - at) : strlen(at);
    return at;
}

/* Every range and default -h gives for an option's values (a parenthesis of its
 * description holding "..", "<=" or "default": "(0 < r <= 16)", "(1..100)",
 * "(default 20 10)") is given in the man page's entry of that option too: each number
 * of it appears there (the man page once gave no range for the filters' radii, nor
 * -render_filter's zoom). man is man -l's text. */
static void check_man_ranges(const char *man)
{
    const char *options = strstr(man, "\nOPTIONS\n");
    if (!options)
        return; /* check_man_groups says so */
    E2eRun r;
    if (!run_help(&r))
        return;
    int checked = 0;
    for (const char *line = r.out; line && *line;) {
        const char *eol = strchr(line, '\n');
        if (strncmp(line, "  -", 3)) {
            line = eol ? eol + 1 : NULL;
            continue;
        }
        char name[64];
        size_t nl = strcspn(line + 2, " ,\n");
        snprintf(name, sizeof name, "%.*s", (int)nl, line + 2);
        /* the entry's description: its first line and the continuation lines (27
         * blanks), joined by blanks */
        char desc[1024];
        size_t dl = 0;
        const char *d = line + 2 + nl;
        for (;;) {
            const char *e = strchr(d, '\n');
            size_t n = e ? (size_t)(e - d) : strlen(d);
            if (dl + n + 2 < sizeof desc) {
                memcpy(desc + dl, d, n);
                dl += n;
                desc[dl++] = ' ';
            }
            if (!e || strncmp(e + 1, "                           ", 27))
                break;
            d = e + 1;
        }
        desc[dl] = '\0';
        line = eol ? eol + 1 : NULL;
        size_t elen = 0;
        const char *entry = man_entry_text(options, name, &elen);
        if (!entry)
            continue; /* check_man_groups says so */
        for (const char *p = strchr(desc, '('); p; p = strchr(p + 1, '(')) {
            const char *q = strchr(p, ')');
            if (!q)
                break;
            char paren[256];
            snprintf(paren, sizeof paren, "%.*s", (int)(q - p - 1), p + 1);
            if (!strstr(paren, "..") && !strstr(paren, "<=") && !strstr(paren, "default"))
                continue;
            for (const char *s = paren; *s;) {
                if (!(*s >= '0' && *s <= '9')) {
                    s++;
                    continue;
                }
                size_t n = strspn(s, "0123456789");
                if (s[n] == '.' && s[n + 1] >= '0' && s[n + 1] <= '9')
                    n += 1 + strspn(s + n + 1, "0123456789");
                char num[32];
                snprintf(num, sizeof num, "%.*s", (int)n, s);
                CHECK_MSG(has_number(entry, elen, num),
                          "the manual page's entry of %s does not give the %s of -h's "
                          "\"(%s)\"", name, num, paren);
                checked++;
                s += n;
            }
        }
    }
    CHECK_MSG(checked >= 20, "only %d numbers of -h's ranges and defaults were found", checked);
    e2e_run_free(&r);
}

static void test_man_page(void)
{
    char man[PATH_MAX], groff[PATH_MAX];
    need_program("man", "man-db", man, sizeof man);
    need_program("groff", "groff", groff, sizeof groff);
    char dest[PATH_MAX], page[PATH_MAX];
    if (!install_to(dest, sizeof dest))
        return;
    e2e_join(page, sizeof page, dest, "usr/local/share/man/man1/raytracer.1");

    /* Every warning groff knows (-ww) is a failure: the page must be clean roff. */
    char *gargv[] = {groff, (char *)"-man", (char *)"-Tutf8", (char *)"-ww", page, NULL};
    E2eRun r;
    CHECK(e2e_run(gargv, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(r.err_len == 0, "groff -ww warns: %.600s", r.err);
    CHECK_MSG(r.out_len > 2000, "groff wrote only %zu bytes", r.out_len);
    e2e_run_free(&r);

    setenv("MANWIDTH", "100", 1);
    setenv("MAN_DISABLE_SECCOMP", "1", 1); /* man-db's sandbox may not exist in containers */
    char *margv[] = {man, (char *)"-l", page, NULL};
    CHECK(e2e_run(margv, &r));
    char why[512];
    CHECK_MSG(r.status == 0, "man -l: %s", e2e_describe(&r, why, sizeof why));
    CHECK_MSG(r.err_len == 0, "man -l printed on stderr: %.600s", r.err);
    static const char *const sections[] = {"NAME", "SYNOPSIS", "DESCRIPTION", "OPTIONS",
                                           "EXIT STATUS", "FILES", "EXAMPLES"};
    for (size_t i = 0; i < sizeof sections / sizeof sections[0]; i++)
        CHECK_MSG(strstr(r.out, sections[i]) != NULL, "the manual page has no %s section",
                  sections[i]);
    /* Every option of the program is documented. */
    char *names[256];
    int n = help_options(names, 256);
    CHECK_MSG(n > 40, "raytracer -h lists only %d options", n);
    for (int i = 0; i < n; i++) {
        CHECK_MSG(has_option(r.out, names[i]), "the manual page does not document %s",
                  names[i]);
        free(names[i]);
    }
    check_man_groups(r.out);
    check_man_ranges(r.out);
    /* and every exit status */
    for (const char *s = "0\0" "1\0" "2\0" "130\0"; *s; s += strlen(s) + 1) {
        char line[32];
        snprintf(line, sizeof line, "\n       %s  ", s);
        CHECK_MSG(strstr(r.out, line) != NULL, "the manual page does not list exit status %s",
                  s);
    }
    e2e_run_free(&r);
    e2e_rmtree(dest);
}

/* Runs a bash script (text) and returns its stdout in r. */
static bool run_bash(const char *bash, const char *dir, const char *text, E2eRun *r)
{
    char script[PATH_MAX];
    e2e_join(script, sizeof script, dir, "test.sh");
    if (!e2e_write_file(script, text))
        return false;
    char *argv[] = {(char *)bash, (char *)"--norc", (char *)"--noprofile", script, NULL};
    return e2e_run(argv, r);
}

/* The completion function, then comp WORDS...: the candidates for the last word,
 * sorted, on one line. */
static const char k_comp_helper[] =
    "comp() { COMP_WORDS=(\"$@\"); COMP_CWORD=$(( $# - 1 )); COMP_LINE=\"$*\";\n"
    "  COMP_POINT=${#COMP_LINE}; COMPREPLY=(); $fn \"$1\" \"${COMP_WORDS[COMP_CWORD]}\"\n"
    "  printf '%s\\n' \"${COMPREPLY[@]}\" | LC_ALL=C sort | tr '\\n' ' '; echo; }\n";

static void test_bash_completion(void)
{
    char bash[PATH_MAX];
    need_program("bash", "bash", bash, sizeof bash);
    char dest[PATH_MAX], file[PATH_MAX], bin[PATH_MAX], path[PATH_MAX];
    if (!install_to(dest, sizeof dest))
        return;
    e2e_join(file, sizeof file, dest, "usr/local/share/bash-completion/completions/raytracer");
    e2e_join(bin, sizeof bin, dest, "usr/local/bin/raytracer");
    /* Files to complete (in DESTDIR/files): a scene, images, a model, a folder. */
    char work[PATH_MAX];
    e2e_join(work, sizeof work, dest, "files");
    CHECK(mkdir(work, 0755) == 0);
    static const char *const files[] = {"a.txt", "b.tga", "c.png", "d.obj", "e.ppm",
                                        "f.cache"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        e2e_join(path, sizeof path, work, files[i]);
        CHECK(e2e_write_file(path, "x"));
    }
    e2e_join(path, sizeof path, work, "sub");
    CHECK(mkdir(path, 0755) == 0);

    static char text[5 * PATH_MAX + 16 * PATH_MAX];
    snprintf(text, sizeof text,
             "cd '%s' || exit 1\n. '%s' || exit 1\n"
             "fn=$(complete -p raytracer | sed 's/.*-F \\([^ ]*\\) .*/\\1/')\n"
             "[ -n \"$fn\" ] || { echo 'no completion for raytracer'; exit 1; }\n%s"
             "comp '%s' -sha\n"
             "comp '%s' -input ''\n"
             "comp '%s' -input a.txt -output ''\n"
             "comp '%s' -depth 1 2 ''\n"
             "comp '%s' -depth 1 ''\n"
             "comp '%s' -accel ''\n"
             "comp '%s' -merge out.tga ''\n"
             "comp '%s' -input a.txt -grid auto -shad\n"
             "comp '%s' -\n"
             "comp '%s' -input a.txt -cache ''\n"
             "comp '%s' -input a.txt -cache f\n"
             "comp '%s' -isa ''\n",
             work, file, k_comp_helper, bin, bin, bin, bin, bin, bin, bin, bin, bin, bin, bin, bin);
    E2eRun r;
    CHECK(run_bash(bash, dest, text, &r));
    char why[512];
    CHECK_MSG(r.status == 0, "bash: %s; stdout: %.300s", e2e_describe(&r, why, sizeof why),
              r.out);
    char *lines[16] = {0};
    int n = 0;
    for (char *p = r.out; p && *p && n < 16;) {
        lines[n++] = p;
        char *eol = strchr(p, '\n');
        if (eol)
            *eol = '\0';
        p = eol ? eol + 1 : NULL;
    }
    CHECK_INT(n, 12);
    if (n == 12) {
        CHECK_STR(lines[0], "-shade_back -shadows ");
        CHECK_STR(lines[1], "a.txt sub ");
        CHECK_STR(lines[2], "b.tga c.png e.ppm sub ");
        CHECK_STR(lines[3], "b.tga c.png e.ppm sub ");
        CHECK_STR(lines[4], " ");                 /* dmax: a number, nothing offered */
        CHECK_STR(lines[5], "grid none twolevel "); /* the names -h lists */
        CHECK_STR(lines[6], "b.tga c.png e.ppm sub ");
        CHECK_STR(lines[7], "-shade_back -shadows ");
        /* every option of -h, once */
        char *names[256];
        int k = help_options(names, 256);
        for (int i = 0; i < k; i++) {
            char word[80];
            snprintf(word, sizeof word, "%s ", names[i]);
            CHECK_MSG(strstr(lines[8], word) != NULL, "completing '-' does not offer %s",
                      names[i]);
            free(names[i]);
        }
        /* the set-up cache: *.cache, not the images (which it never replaces); they
         * hid frame.cache, so '-cache f' completed nothing */
        CHECK_STR(lines[9], "f.cache sub ");
        CHECK_STR(lines[10], "f.cache ");
        CHECK_STR(lines[11], "avx2 avx512 base "); /* the sets -isa's line names */
    }
    e2e_run_free(&r);

    /* The way a user gets it: bash-completion finds the file under DESTDIR's share/
     * (XDG_DATA_DIRS) when raytracer is first completed. */
    const char *loader = "/usr/share/bash-completion/bash_completion";
    if (!e2e_exists(loader)) {
        e2e_rmtree(dest);
        missing_tool("bash-completion not found (apt-get install bash-completion)");
    }
    snprintf(text, sizeof text,
             "cd '%s' || exit 1\nexport XDG_DATA_DIRS='%s/usr/local/share'\n"
             "shopt -s progcomp\n. %s\n"
             "__load_completion raytracer || { echo 'not loaded'; exit 1; }\n"
             "fn=$(complete -p raytracer | sed 's/.*-F \\([^ ]*\\) .*/\\1/')\n%s"
             "comp '%s' -sha\n",
             work, dest, loader, k_comp_helper, bin);
    CHECK(run_bash(bash, dest, text, &r));
    CHECK_MSG(r.status == 0, "bash with bash-completion: %s; stdout: %.300s",
              e2e_describe(&r, why, sizeof why), r.out);
    CHECK_STR(r.out, "-shade_back -shadows \n");
    e2e_run_free(&r);
    e2e_rmtree(dest);
}

static const TestCase tests[] = {
    {"install_uninstall", test_install_uninstall},
    {"install_prefix_doc", test_install_prefix_doc},
    {"install_man_page", test_man_page},
    {"install_bash_completion", test_bash_completion},
};

RT_TEST_MAIN(tests)
