/* Directional and point lights (A2, A4): direction towards the light, colour, and for
 * point lights the distance and the course's attenuation. */
#include "rt/light.h"

void light_illuminate(const Light *l, Vec3 p, Vec3 *dir_to_light, Vec3 *color, float *dist)
{
    if (l->kind == LIGHT_DIRECTIONAL) {
        *dir_to_light = v3_neg(l->direction);
        *color = l->color;
        *dist = INFINITY;
        return;
    }
    Vec3 to = v3_sub(l->position, p);
    float d = v3_length(to);
    *dir_to_light = v3_normalize(to);
    *dist = d;
    float denom = l->attenuation[0] + l->attenuation[1] * d + l->attenuation[2] * d * d;
    /* The course's factor 1/denom, clamped to >= 0; a zero or negative denominator
     * (attenuation 0 0 0, or negative coefficients) gives no light rather than inf. */
    float f = denom > 0.0f ? 1.0f / denom : 0.0f;
    *color = v3_scale(l->color, f);
}
