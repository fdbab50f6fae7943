/* The project's own tiny test harness: every test runs in a forked child, so a crash
 * fails one test, not the run. A test binary ends with "N passed, N failed" (and
 * ", N skipped" when some were skipped, each with its reason printed). */
#ifndef RT_TEST_HARNESS_H
#define RT_TEST_HARNESS_H

#include <math.h>
#include <stdio.h>
#include <string.h>

typedef void (*TestFn)(void);

typedef struct TestCase {
    const char *name;
    TestFn fn;
} TestCase;

/* Failure bookkeeping of the running test (in the child process). */
extern int harness_failures;
void harness_fail(const char *file, int line, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* Ends the current test as skipped with a reason (exit code 77 in the child); a test
 * with a failed check before the skip ends failed instead. */
void harness_skip(const char *reason) __attribute__((noreturn));
int harness_main(int argc, char **argv, const TestCase *tests, int count);

/* Paths for end-to-end tests: the binary under test and the course data folder
 * (environment RT_BIN, RT_COURSE; defaults ./raytracer and ../shared/course). */
const char *harness_bin(void);
const char *harness_course_dir(void); /* NULL when the folder is absent */
const char *harness_root(void);       /* repository root (environment RT_ROOT or ".") */

#define CHECK(cond) \
    do { if (!(cond)) harness_fail(__FILE__, __LINE__, "CHECK(%s)", #cond); } while (0)
#define CHECK_MSG(cond, ...) \
    do { if (!(cond)) harness_fail(__FILE__, __LINE__, __VA_ARGS__); } while (0)
#define CHECK_INT(a, b) \
    do { long long a_ = (long long)(a), b_ = (long long)(b); \
         if (a_ != b_) harness_fail(__FILE__, __LINE__, "%s == %lld, expected %s == %lld", \
                                    #a, a_, #b, b_); } while (0)
#define CHECK_NEAR(a, b, eps) \
    do { double a_ = (double)(a), b_ = (double)(b); \
         if (!(fabs(a_ - b_) <= (eps))) harness_fail(__FILE__, __LINE__, \
             "%s = %.9g, expected %.9g (eps %g)", #a, a_, b_, (double)(eps)); } while (0)
#define CHECK_STR(a, b) \
    do { const char *a_ = (a), *b_ = (b); \
         if (!a_ || !b_ || strcmp(a_, b_) != 0) harness_fail(__FILE__, __LINE__, \
             "%s = \"%s\", expected \"%s\"", #a, a_ ? a_ : "(null)", b_ ? b_ : "(null)"); \
    } while (0)
#define CHECK_CONTAINS(hay, needle) \
    do { const char *h_ = (hay), *n_ = (needle); \
         if (!h_ || !strstr(h_, n_)) harness_fail(__FILE__, __LINE__, \
             "\"%s\" does not contain \"%s\"", h_ ? h_ : "(null)", n_); } while (0)

#define TEST_LIST_COUNT(list) ((int)(sizeof(list) / sizeof((list)[0])))
#define RT_TEST_MAIN(list) \
    int main(int argc, char **argv) { return harness_main(argc, argv, list, TEST_LIST_COUNT(list)); }

#endif
