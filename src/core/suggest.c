/* "Did you mean" (rt/suggest.h): optimal-string-alignment distance over the known names. */
#include "rt/suggest.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Words longer than this are not misspelt names: no suggestion, no big tables. */
#define SUGGEST_MAX_LEN 64

int suggest_distance(const char *a, const char *b)
{
    size_t n = strlen(a), m = strlen(b);
    if (n > SUGGEST_MAX_LEN || m > SUGGEST_MAX_LEN)
        return SUGGEST_MAX_LEN * 2;
    /* Three rows of the dynamic-programming table: the swap looks two rows back. */
    int rows[3][SUGGEST_MAX_LEN + 1];
    int *prev2 = rows[0], *prev = rows[1], *cur = rows[2];
    for (size_t j = 0; j <= m; j++)
        prev[j] = (int)j;
    for (size_t i = 1; i <= n; i++) {
        cur[0] = (int)i;
        int ca = tolower((unsigned char)a[i - 1]);
        for (size_t j = 1; j <= m; j++) {
            int cb = tolower((unsigned char)b[j - 1]);
            int best = prev[j - 1] + (ca != cb);
            if (prev[j] + 1 < best)
                best = prev[j] + 1;
            if (cur[j - 1] + 1 < best)
                best = cur[j - 1] + 1;
            if (i > 1 && j > 1 && ca == tolower((unsigned char)b[j - 2]) &&
                tolower((unsigned char)a[i - 2]) == cb && prev2[j - 2] + 1 < best)
                best = prev2[j - 2] + 1;
            cur[j] = best;
        }
        int *t = prev2;
        prev2 = prev;
        prev = cur;
        cur = t;
    }
    return prev[m];
}

static int starts_with_ci(const char *s, const char *prefix)
{
    for (; *prefix; s++, prefix++)
        if (tolower((unsigned char)*s) != tolower((unsigned char)*prefix))
            return 0;
    return 1;
}

int suggest_find(const char *word, const char *const *names, size_t count, const char **out,
                 int max)
{
    size_t len = strlen(word);
    if (len == 0 || len > SUGGEST_MAX_LEN || max <= 0)
        return 0;
    /* A third of the word may be wrong (at least one character): "-shadow", "Sphre",
     * "Phongmaterial" (case only), "-sahdows" (a swap). */
    int limit = (int)len / 3 > 1 ? (int)len / 3 : 1;
    size_t typed = strspn(word, "-");
    if (len - typed < 2)
        return 0; /* "-g": too little typed to guess from */
    int best = limit, found = 0;
    for (size_t i = 0; i < count; i++) {
        int d = suggest_distance(word, names[i]);
        if (d > best)
            continue;
        if (d < best) {
            best = d;
            found = 0;
        }
        if (found < max)
            out[found++] = names[i];
    }
    if (found > 0)
        return found;
    /* An abbreviation: "-sha" is the start of -shadows and -shade_back. */
    for (size_t i = 0; i < count && found < max; i++)
        if (strlen(names[i]) > len && starts_with_ci(names[i], word))
            out[found++] = names[i];
    return found;
}

void suggest_format(char *buf, size_t size, const char *word, const char *const *names,
                    size_t count)
{
    const char *hits[3];
    int n = suggest_find(word, names, count, hits, 3);
    if (size)
        buf[0] = '\0';
    if (n == 0)
        return;
    size_t used = (size_t)snprintf(buf, size, " (did you mean ");
    for (int i = 0; i < n && used < size; i++)
        used += (size_t)snprintf(buf + used, size - used, "%s%s", hits[i],
                                 i == n - 1 ? "?)" : i == n - 2 ? " or " : ", ");
}
