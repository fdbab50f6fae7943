/* Private to src/scene: the recursive-descent parser of the scene grammar
 * (docs/scene-format.md), filling a Scene whose arena is already initialised. */
#ifndef RT_SCENE_PARSER_H
#define RT_SCENE_PARSER_H

#include <stdbool.h>
#include <stddef.h>
#include "rt/scene.h"

/* Parses len bytes of buf (name for messages; base_dir for obj_file names, NULL = the
 * working directory only). False after reporting the first error to diag; the caller
 * then frees the arena. */
bool scene_parse(Scene *s, const char *buf, size_t len, const char *name,
                 const char *base_dir, Diag *diag);

#endif
