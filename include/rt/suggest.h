/* "Did you mean": the known names closest to a misspelt word (options, scene keywords),
 * by edit distance, so messages can offer the right spelling. */
#ifndef RT_SUGGEST_H
#define RT_SUGGEST_H

#include <stddef.h>

/* Edit distance between a and b (insertions, deletions, substitutions and swaps of two
 * neighbouring characters cost 1), comparing letters without regard to case. */
int suggest_distance(const char *a, const char *b);

/* The names (at most max, pointers into names) close enough to word to be what was
 * meant: those at the smallest edit distance when it is small for the word's length,
 * or else those that start with word (at least two characters typed). Returns how many. */
int suggest_find(const char *word, const char *const *names, size_t count, const char **out,
                 int max);

/* " (did you mean X?)", " (did you mean X or Y?)", " (did you mean X, Y or Z?)", or "",
 * into buf. */
void suggest_format(char *buf, size_t size, const char *word, const char *const *names,
                    size_t count);

#endif
