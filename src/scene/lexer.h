/* Private to src/scene: the scene-file tokenizer (docs/scene-format.md). Tokens are maximal
 * runs of non-whitespace bytes, each located file:line:col (1-based, col in characters:
 * lex_chars), and carry their length (they are not NUL-terminated). A control byte (below 0x20 other
 * than whitespace, or 0x7f) is a located error. */
#ifndef RT_SCENE_LEXER_H
#define RT_SCENE_LEXER_H

#include <stdbool.h>
#include <stddef.h>
#include "rt/diag.h"

/* Longer tokens are an error (the course's limit is 100; nothing legal comes close). */
enum { LEX_MAX_TOKEN = 4096 };

typedef struct Token {
    const char *text;   /* points into the lexer's buffer; NOT NUL-terminated */
    size_t len;         /* 0 at end of file */
    SrcLoc loc;
} Token;

typedef struct Lexer {
    const char *buf;    /* borrowed; len bytes (may contain NUL bytes: binary garbage) */
    size_t len, pos;
    int line, col;      /* of buf[pos] */
    const char *file;   /* for locations */
    Diag *diag;
    bool has_peek;
    Token peeked;
} Lexer;

/* Bytes of the UTF-8 character at p (n > 0 bytes there): its lead byte and the
 * continuation bytes it announces; 1 for a byte that begins no valid character (a stray
 * continuation byte, a sequence cut short), which an editor shows as one replacement
 * character, so it counts as one too. */
size_t lex_char_bytes(const char *p, size_t n);
/* Characters in the n bytes at p (lex_char_bytes): what a column counts, so an error
 * after "é" or "→" on a line is where an editor shows it, not 1 or 2 columns on. */
size_t lex_chars(const char *p, size_t n);

void lex_init(Lexer *lx, const char *buf, size_t len, const char *file, Diag *diag);

/* The next token (len 0 at end of file, located just past the last byte). False after
 * reporting an over-long token. */
bool lex_next(Lexer *lx, Token *t);
/* The next token without consuming it. */
bool lex_peek(Lexer *lx, Token *t);

/* Compares the token's len bytes with the C string kw; never reads kw past its NUL,
 * whatever bytes the token holds. */
static inline bool lex_is(const Token *t, const char *kw)
{
    size_t i = 0;
    for (; i < t->len; i++)
        if (kw[i] == '\0' || kw[i] != t->text[i])
            return false;
    return kw[i] == '\0';
}
static inline bool lex_eof(const Token *t) { return t->len == 0; }

/* A printable, bounded rendering of a token for messages: non-printable bytes as \xNN,
 * long tokens cut with "...". "end of file" for the EOF token. */
const char *lex_show(const Token *t, char *out, size_t size);

/* Number conversions of a whole token (what the course's fscanf "%f" / "%d" accept, but
 * the entire token must be the number). They report located errors themselves. */
typedef enum NumResult { NUM_OK, NUM_NOT_A_NUMBER, NUM_NOT_INTEGER, NUM_RANGE } NumResult;
NumResult lex_to_float(const Token *t, float *out);
NumResult lex_to_int(const Token *t, int *out);

#endif
