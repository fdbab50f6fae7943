/* Scene-file tokenizer: whitespace-separated tokens with file:line:col locations and
 * strict whole-token number conversion (docs/scene-format.md). */
#include "lexer.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void lex_init(Lexer *lx, const char *buf, size_t len, const char *file, Diag *diag)
{
    memset(lx, 0, sizeof *lx);
    lx->buf = buf;
    lx->len = len;
    lx->file = file;
    lx->diag = diag;
    lx->line = 1;
    lx->col = 1;
    /* A UTF-8 byte-order mark, which some editors put at the start of every text file
     * they save, is not part of the first keyword: skipped, and columns count from
     * the character after it (where the editor shows column 1). */
    if (len >= 3 && memcmp(buf, "\xEF\xBB\xBF", 3) == 0)
        lx->pos = 3;
}

size_t lex_char_bytes(const char *p, size_t n)
{
    unsigned char c = (unsigned char)p[0];
    /* The sequence length a valid lead byte announces (RFC 3629: C2..F4 lead). */
    size_t k = c < 0x80                ? 1
               : c >= 0xc2 && c <= 0xdf ? 2
               : c >= 0xe0 && c <= 0xef ? 3
               : c >= 0xf0 && c <= 0xf4 ? 4
                                        : 0;
    if (k == 0 || k > n)
        return 1;
    for (size_t i = 1; i < k; i++)
        if (((unsigned char)p[i] & 0xc0) != 0x80)
            return 1;
    return k;
}

size_t lex_chars(const char *p, size_t n)
{
    size_t chars = 0;
    for (size_t i = 0; i < n; chars++)
        i += lex_char_bytes(p + i, n - i);
    return chars;
}

/* fscanf's %s stops at isspace() in the C locale; CR counts, so CRLF files read alike. */
static bool is_space(unsigned char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

static bool lex_scan(Lexer *lx, Token *t)
{
    while (lx->pos < lx->len && is_space((unsigned char)lx->buf[lx->pos])) {
        /* A CR not followed by LF (classic Mac OS line ends) ends a line too, as an
         * editor shows it: otherwise such a file is all line 1 in every message. */
        char c = lx->buf[lx->pos];
        if (c == '\n' ||
            (c == '\r' && (lx->pos + 1 >= lx->len || lx->buf[lx->pos + 1] != '\n'))) {
            lx->line++;
            lx->col = 1;
        } else {
            lx->col++;
        }
        lx->pos++;
    }
    t->loc.file = lx->file;
    t->loc.line = lx->line;
    t->loc.col = lx->col;
    t->text = lx->buf + lx->pos;
    size_t start = lx->pos;
    /* Columns count characters, not bytes: an editor (and gcc's default column unit)
     * puts 'x' in "é x" at column 3, not 4. extra counts the token's bytes so far that
     * begin no character (a character's continuation bytes). */
    size_t extra = 0;
    while (lx->pos < lx->len) {
        unsigned char c = (unsigned char)lx->buf[lx->pos];
        /* A printable ASCII byte other than the space, the common case first: one byte
         * a character. (Asking lex_char_bytes for every byte made the scene reader's
         * lexing 29% dearer, c172987; regress37, bench/REPORT.txt.) */
        if ((unsigned)(c - 0x21u) < 0x5eu) {
            lx->pos++;
            continue;
        }
        if (is_space(c))
            break;
        /* Scene files are text: a NUL or other control byte is never part of a token
         * (it would end a C string early, and it is never what the author meant). */
        if (c < 0x20 || c == 0x7f) {
            SrcLoc at = t->loc;
            size_t col = (size_t)lx->col + (lx->pos - start - extra);
            at.col = col > INT_MAX ? INT_MAX : (int)col;
            diag_error(lx->diag, &at, "control byte \\x%02x in the scene (scene files are text)",
                       c);
            return false;
        }
        /* A character's continuation bytes are 0x80..0xbf: never white space or a
         * control byte, so the whole character belongs to the token. */
        size_t k = lex_char_bytes(lx->buf + lx->pos, lx->len - lx->pos);
        lx->pos += k;
        extra += k - 1;
    }
    size_t chars = lx->pos - start - extra;
    t->len = lx->pos - start;
    /* A token never contains a newline. Saturate on absurd lines. */
    size_t col = (size_t)lx->col + chars;
    lx->col = col > INT_MAX ? INT_MAX : (int)col;
    if (t->len > LEX_MAX_TOKEN) {
        diag_error(lx->diag, &t->loc, "token too long (%zu characters, the limit is %d)",
                   t->len, LEX_MAX_TOKEN);
        return false;
    }
    return true;
}

bool lex_next(Lexer *lx, Token *t)
{
    if (lx->has_peek) {
        *t = lx->peeked;
        lx->has_peek = false;
        return true;
    }
    return lex_scan(lx, t);
}

bool lex_peek(Lexer *lx, Token *t)
{
    if (!lx->has_peek) {
        if (!lex_scan(lx, &lx->peeked))
            return false;
        lx->has_peek = true;
    }
    *t = lx->peeked;
    return true;
}

const char *lex_show(const Token *t, char *out, size_t size)
{
    enum { SHOW_MAX = 60 };
    if (lex_eof(t)) {
        snprintf(out, size, "end of file");
        return out;
    }
    size_t o = 0;
    for (size_t i = 0; i < t->len; i++) {
        unsigned char c = (unsigned char)t->text[i];
        if (i >= SHOW_MAX || o + 8 >= size) {
            if (o + 4 <= size) {
                memcpy(out + o, "...", 3);
                o += 3;
            }
            break;
        }
        if (c >= 0x20 && c < 0x7f && c != '\\') {
            out[o++] = (char)c;
        } else {
            snprintf(out + o, size - o, "\\x%02x", c);
            o += 4;
        }
    }
    out[o < size ? o : size - 1] = '\0';
    return out;
}

/* Copies the token into buf as a C string; false if it holds a NUL byte. */
static bool lex_cstr(const Token *t, char *buf, size_t size)
{
    if (t->len == 0 || t->len >= size || memchr(t->text, '\0', t->len))
        return false;
    memcpy(buf, t->text, t->len);
    buf[t->len] = '\0';
    return true;
}

NumResult lex_to_float(const Token *t, float *out)
{
    char buf[LEX_MAX_TOKEN + 1];
    if (!lex_cstr(t, buf, sizeof buf))
        return NUM_NOT_A_NUMBER;
    char *end;
    errno = 0;
    /* strtof: the very conversion fscanf("%f") performs, so values are bit-identical. */
    float v = strtof(buf, &end);
    if (end == buf || *end != '\0')
        return NUM_NOT_A_NUMBER;
    if (!isfinite(v))
        return NUM_RANGE; /* nan, inf, and overflow (HUGE_VALF) */
    *out = v;             /* underflow to 0 or a subnormal is harmless: accepted */
    return NUM_OK;
}

NumResult lex_to_int(const Token *t, int *out)
{
    char buf[LEX_MAX_TOKEN + 1];
    if (!lex_cstr(t, buf, sizeof buf))
        return NUM_NOT_A_NUMBER;
    char *end;
    errno = 0;
    long v = strtol(buf, &end, 10);
    if (end == buf || *end != '\0') {
        float f;
        return lex_to_float(t, &f) == NUM_NOT_A_NUMBER ? NUM_NOT_A_NUMBER : NUM_NOT_INTEGER;
    }
    if (errno == ERANGE || v > INT_MAX || v < INT_MIN)
        return NUM_RANGE;
    *out = (int)v;
    return NUM_OK;
}
