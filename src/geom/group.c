/* Group (A1): a list of objects; intersects all children, keeps the nearest hit. */
#include "rt/geom.h"
#include "rt/arena.h"

#include "group_internal.h"

static bool group_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                            RenderCtx *ctx)
{
    const Group *g = (const Group *)self;
    bool any = false;
    for (int i = 0; i < g->count; i++)
        if (g->children[i])
            any |= obj_intersect(g->children[i], ray, hit, tmin, ctx);
    return any;
}

/* Shadow rays: the first occluding child settles it. */
static bool group_occluded(const Object3D *self, const Ray *ray, float tmin, float tmax,
                           RenderCtx *ctx)
{
    const Group *g = (const Group *)self;
    for (int i = 0; i < g->count; i++)
        if (g->children[i] && obj_occluded(g->children[i], ray, tmin, tmax, ctx))
            return true;
    return false;
}

static const Object3DOps group_ops = {.type_name = "Group", .kind = OBJ_GROUP,
                                      .intersect = group_intersect,
                                      .occluded = group_occluded};

/* A new Group in g's memory with the given children array. */
static Object3D *group_init(Group *g, int capacity, Object3D **children)
{
    g->children = children;
    g->count = capacity;
    g->base.ops = &group_ops;
    g->base.bbox = bbox_empty();
    g->base.id = RT_NO_ID;
    return &g->base;
}

Object3D *group_new(Arena *a, int capacity)
{
    if (capacity < 0)
        return NULL;
    Group *g = arena_alloc(a, sizeof *g);
    if (!g)
        return NULL;
    Object3D **children = arena_calloc(a, capacity ? (size_t)capacity : 1, sizeof *children);
    if (!children)
        return NULL;
    return group_init(g, capacity, children);
}

Object3D *group_new_with(Arena *a, int capacity, Object3D **children)
{
    if (capacity < 0)
        return NULL;
    Group *g = arena_alloc(a, sizeof *g);
    return g ? group_init(g, capacity, children) : NULL;
}

void group_set_child(Object3D *group, int index, Object3D *child)
{
    Group *g = (Group *)group;
    if (index >= 0 && index < g->count)
        g->children[index] = child;
}

void group_finish(Object3D *group)
{
    Group *g = (Group *)group;
    BBox b = bbox_empty();
    bool bounded = false;
    for (int i = 0; i < g->count; i++) {
        const Object3D *c = g->children[i];
        if (c && c->bounded) {
            b = bbox_union(b, c->bbox);
            bounded = true;
        }
    }
    g->base.bbox = b;
    g->base.bounded = bounded;
}

int group_count(const Object3D *group) { return ((const Group *)group)->count; }

const Object3D *group_child(const Object3D *group, int index)
{
    const Group *g = (const Group *)group;
    return (index >= 0 && index < g->count) ? g->children[index] : NULL;
}

/* Depth-first numbering of the leaves: the brute-force loop meets primitives in this
 * order, so hit_accepts' tie-break by id reproduces its choice everywhere. */
static uint32_t assign(Object3D *o, uint32_t next)
{
    if (!o)
        return next;
    switch (obj_kind(o)) {
    case OBJ_GROUP: {
        Group *g = (Group *)o;
        for (int i = 0; i < g->count; i++)
            next = assign(g->children[i], next);
        return next;
    }
    case OBJ_TRANSFORM:
        return assign((Object3D *)transform_child(o), next);
    default:
        o->id = next;
        return next + 1;
    }
}

uint32_t group_assign_ids(Object3D *root) { return assign(root, 0); }
