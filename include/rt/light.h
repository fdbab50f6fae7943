/* Lights (A2, A4): directional and point with attenuation. */
#ifndef RT_LIGHT_H
#define RT_LIGHT_H

#include "rt/vec.h"

typedef enum LightKind { LIGHT_DIRECTIONAL, LIGHT_POINT } LightKind;

typedef struct Light {
    LightKind kind;
    Vec3 direction;     /* directional: unit direction the light travels */
    Vec3 position;      /* point */
    Vec3 color;
    float attenuation[3]; /* point: constant, linear, quadratic; default 1 0 0 */
} Light;

/* At world point p: unit direction to the light, attenuated colour, and distance
 * (INFINITY for directional lights). Attenuation factor clamped to >= 0. */
void light_illuminate(const Light *l, Vec3 p, Vec3 *dir_to_light, Vec3 *color, float *dist);

#endif
