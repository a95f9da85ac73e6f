/* "Did you mean ...?": the nearest of a list of valid words to a mistyped one, and the
 * list itself for messages, so every unknown flag, key or name is answered the same way. */
#ifndef VDBSCATTER_SUGGEST_H
#define VDBSCATTER_SUGGEST_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The candidate closest to word by edit distance (a transposition counts as one edit),
 * or NULL when none is close enough to be a plausible typo: at most 1 edit for words of up
 * to 4 characters, 2 up to 8, else 3. candidates ends with NULL. */
const char *vdbs_suggest(const char *word, const char *const *candidates);

/* " (did you mean \"X\"?)" into buf, or "" when vdbs_suggest finds nothing. */
void vdbs_suggest_hint(const char *word, const char *const *candidates, char *buf, size_t size);

/* "a, b, c" into buf (truncated with "..." if it does not fit). */
void vdbs_join_names(const char *const *names, char *buf, size_t size);

#ifdef __cplusplus
}
#endif

#endif
