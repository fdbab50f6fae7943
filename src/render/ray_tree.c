/* Ray-tree recording for the GUI `t` key (course RayTree), bounded arrays only. */
#include "rt/ray_tree.h"

void ray_tree_clear(RayTree *t)
{
    t->num_segments = 0;
    t->dropped = 0;
    t->num_cells = 0;
}

static float clampf(float x, float lo, float hi) { return x < lo ? lo : x > hi ? hi : x; }

void ray_tree_add_segment(RayTree *t, RaySegKind kind, const Ray *ray, float t0, float t1)
{
    if (ray_tree_full(t)) {
        t->dropped++;
        return;
    }
    /* The course clamps the drawn segments to t in [-100, 100]. */
    t0 = clampf(t0, -100.0f, 100.0f);
    t1 = clampf(t1, -100.0f, 100.0f);
    RaySegment *s = &t->segments[t->num_segments++];
    s->kind = kind;
    s->a = ray_at(ray, t0);
    s->b = ray_at(ray, t1);
}

void ray_tree_add_cell(RayTree *t, int i, int j, int k, Vec3 entered_normal)
{
    if (t->num_cells >= RT_RAYTREE_MAX_CELLS)
        return;
    RayTreeCell *c = &t->cells[t->num_cells++];
    c->i = i;
    c->j = j;
    c->k = k;
    c->entered_normal = entered_normal;
}
