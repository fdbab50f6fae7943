/* Fixed-function OpenGL drawing of the preview (course GLCanvas/paint(), docs/preview.md):
 * objects with their Phong parameters, lights, grid cells, ray tree, traced rows. */
#if defined(RT_HAVE_GLUT) || defined(RT_HAVE_OSMESA)
#include "draw.h"

#include <math.h>
#include <string.h>
#include "rt/geom.h"
#include "rt/grid.h"
#include "rt/material.h"
#include "rt/raytracer.h"
#include "rt/scene.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Half size of the quad standing in for an infinite plane (the course uses a huge
 * quad, big < 1e6); far beyond the far clipping plane, small enough for floats. */
#define PLANE_HALF_SIZE 1.0e4f
/* The course GLCanvas's near plane and minimum far plane. */
#define NEAR_PLANE 0.5f
#define MIN_FAR_PLANE 40.0f

typedef struct DrawCtx {
    const GlApi *gl;
    const PreviewView *v;
    const Material *last;   /* the material currently set, to skip repeats */
} DrawCtx;

static void set_phong(DrawCtx *d, const Material *m)
{
    if (!m || m == d->last)
        return;
    d->last = m;
    PhongParams p;
    if (!phong_params(mat_preview(m), &p))
        p = phong_defaults();
    /* glSetMaterial: ambient = diffuse = diffuseColor, specular, shininess clamped to
     * GL's [0, 128]. */
    float diff[4] = {p.diffuse.x, p.diffuse.y, p.diffuse.z, 1.0f};
    float spec[4] = {p.specular.x, p.specular.y, p.specular.z, 1.0f};
    float shin = fmaxf(0.0f, fminf(128.0f, p.exponent));
    d->gl->Materialfv(GL_FRONT_AND_BACK, GL_AMBIENT, diff);
    d->gl->Materialfv(GL_FRONT_AND_BACK, GL_DIFFUSE, diff);
    d->gl->Materialfv(GL_FRONT_AND_BACK, GL_SPECULAR, spec);
    d->gl->Materialf(GL_FRONT_AND_BACK, GL_SHININESS, shin);
}

static void set_diffuse_only(DrawCtx *d, Vec3 c)
{
    float diff[4] = {c.x, c.y, c.z, 1.0f};
    float zero[4] = {0, 0, 0, 1};
    d->gl->Materialfv(GL_FRONT_AND_BACK, GL_AMBIENT, diff);
    d->gl->Materialfv(GL_FRONT_AND_BACK, GL_DIFFUSE, diff);
    d->gl->Materialfv(GL_FRONT_AND_BACK, GL_SPECULAR, zero);
    d->gl->Materialf(GL_FRONT_AND_BACK, GL_SHININESS, 1.0f);
    d->last = NULL;
}

static void vertex(const GlApi *gl, Vec3 p) { gl->Vertex3f(p.x, p.y, p.z); }
static void normal(const GlApi *gl, Vec3 n) { gl->Normal3f(n.x, n.y, n.z); }

/* Point and normal of the unit sphere at longitude theta, latitude phi. */
static Vec3 sphere_dir(float theta, float phi)
{
    return v3(cosf(phi) * cosf(theta), sinf(phi), cosf(phi) * sinf(theta));
}

static void draw_sphere(DrawCtx *d, const Object3D *o)
{
    const GlApi *gl = d->gl;
    const PreviewConfig *cfg = d->v->cfg;
    int nt = cfg->tess_theta > 2 ? cfg->tess_theta : 3;
    int np = cfg->tess_phi > 1 ? cfg->tess_phi : 2;
    Vec3 c = sphere_center(o);
    float r = sphere_radius(o);
    set_phong(d, o->material);
    /* theta 0..360 degrees, phi -90..90 (the course's tessellation); flat facets use the
     * normal at the facet's middle, -gouraud the sphere's normal at each vertex. */
    gl->Begin(GL_QUADS);
    for (int b = 0; b < np; b++) {
        float p0 = (float)(-M_PI / 2 + M_PI * b / np);
        float p1 = (float)(-M_PI / 2 + M_PI * (b + 1) / np);
        for (int a = 0; a < nt; a++) {
            float t0 = (float)(2 * M_PI * a / nt);
            float t1 = (float)(2 * M_PI * (a + 1) / nt);
            Vec3 n[4] = {sphere_dir(t0, p0), sphere_dir(t0, p1), sphere_dir(t1, p1),
                         sphere_dir(t1, p0)};
            if (!cfg->gouraud)
                normal(gl, sphere_dir(0.5f * (t0 + t1), 0.5f * (p0 + p1)));
            for (int k = 0; k < 4; k++) {
                if (cfg->gouraud)
                    normal(gl, n[k]);
                vertex(gl, v3_madd(c, n[k], r));
            }
        }
    }
    gl->End();
}

static void draw_plane(DrawCtx *d, const Object3D *o)
{
    const GlApi *gl = d->gl;
    Vec3 n = plane_normal(o);
    float len2 = v3_dot(n, n);
    if (!(len2 > 0.0f))
        return;
    /* Centred at the projection of the origin onto the plane. */
    Vec3 c = v3_scale(n, plane_offset(o) / len2);
    Vec3 un = v3_normalize(n);
    Vec3 helper = fabsf(un.x) < 0.9f ? v3(1, 0, 0) : v3(0, 1, 0);
    Vec3 s = v3_scale(v3_normalize(v3_cross(un, helper)), PLANE_HALF_SIZE);
    Vec3 t = v3_scale(v3_cross(un, v3_normalize(s)), PLANE_HALF_SIZE);
    set_phong(d, o->material);
    gl->Begin(GL_QUADS);
    normal(gl, un);
    vertex(gl, v3_sub(v3_sub(c, s), t));
    vertex(gl, v3_sub(v3_add(c, s), t));
    vertex(gl, v3_add(v3_add(c, s), t));
    vertex(gl, v3_add(v3_sub(c, s), t));
    gl->End();
}

/* Row-major Mat4 -> GL's column-major array. */
static void to_gl_matrix(const Mat4 *m, float out[16])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            out[c * 4 + r] = m->m[r][c];
}

/* Triangles are gathered into one glBegin/glEnd run per group of siblings. */
static void draw_object(DrawCtx *d, const Object3D *o, bool *in_tris);

static void end_tris(DrawCtx *d, bool *in_tris)
{
    if (*in_tris) {
        d->gl->End();
        *in_tris = false;
    }
}

static void draw_object(DrawCtx *d, const Object3D *o, bool *in_tris)
{
    const GlApi *gl = d->gl;
    switch (obj_kind(o)) {
    case OBJ_GROUP:
        for (int k = 0; k < group_count(o); k++) {
            const Object3D *child = group_child(o, k);
            if (child)
                draw_object(d, child, in_tris);
        }
        break;
    case OBJ_TRIANGLE: {
        /* glMaterial may not be called between glBegin/glEnd for every change; end the
         * run when the material changes. */
        if (o->material != d->last)
            end_tris(d, in_tris);
        set_phong(d, o->material);
        if (!*in_tris) {
            gl->Begin(GL_TRIANGLES);
            *in_tris = true;
        }
        Vec3 v[3];
        triangle_vertices(o, v);
        normal(gl, triangle_normal(o));
        vertex(gl, v[0]);
        vertex(gl, v[1]);
        vertex(gl, v[2]);
        break;
    }
    case OBJ_SPHERE:
        end_tris(d, in_tris);
        draw_sphere(d, o);
        break;
    case OBJ_PLANE:
        end_tris(d, in_tris);
        draw_plane(d, o);
        break;
    case OBJ_TRANSFORM: {
        end_tris(d, in_tris);
        float m[16];
        to_gl_matrix(transform_matrix(o), m);
        gl->PushMatrix();
        gl->MultMatrixf(m);
        bool inner = false;
        draw_object(d, transform_child(o), &inner);
        end_tris(d, &inner);
        gl->PopMatrix();
        break;
    }
    default:
        /* A kind the preview has not been taught to draw (OBJ_OTHER) is left out of it:
         * the ray tracer still renders it (docs/architecture.md). */
        break;
    }
}

/* Far plane: at least the course's 40, and far enough for the whole scene box so the
 * preview shows what the ray tracer sees. */
static float far_plane(const Camera *c, const BBox *b)
{
    float far = MIN_FAR_PLANE;
    if (bbox_is_empty(b))
        return far;
    for (int k = 0; k < 8; k++) {
        Vec3 p = v3(k & 1 ? b->max.x : b->min.x, k & 2 ? b->max.y : b->min.y,
                    k & 4 ? b->max.z : b->min.z);
        float depth = fabsf(v3_dot(v3_sub(p, c->center), c->direction));
        if (isfinite(depth))
            far = fmaxf(far, 1.5f * depth + 1.0f);
    }
    return far;
}

/* Projection and camera placement matching the ray tracer exactly (rt/camera.h):
 * the square screen spans the LARGER window side, the smaller one is cropped. */
static void setup_camera(const GlApi *gl, const Camera *c, const BBox *bounds, int w, int h)
{
    double s = (double)(w > h ? w : h);
    double fx = (double)w / s, fy = (double)h / s;
    float far = far_plane(c, bounds);
    gl->MatrixMode(GL_PROJECTION);
    gl->LoadIdentity();
    if (c->kind == CAMERA_ORTHOGRAPHIC) {
        /* The ray tracer's orthographic rays start at t = -inf, so objects behind the
         * image plane are visible: the near plane goes behind the camera as well. */
        double hs = 0.5 * (double)c->size;
        gl->Ortho(-hs * fx, hs * fx, -hs * fy, hs * fy, -(double)far, (double)far);
    } else {
        double t = tan(0.5 * (double)c->angle) * (double)NEAR_PLANE;
        gl->Frustum(-t * fx, t * fx, -t * fy, t * fy, (double)NEAR_PLANE, (double)far);
    }
    /* gluLookAt(center, center + direction, up) with the ray tracer's own basis. */
    Vec3 r = c->horizontal, u = c->up, d = c->direction, e = c->center;
    float m[16] = {r.x, u.x, -d.x, 0, r.y, u.y, -d.y, 0, r.z, u.z, -d.z, 0,
                   -v3_dot(r, e), -v3_dot(u, e), v3_dot(d, e), 1};
    gl->MatrixMode(GL_MODELVIEW);
    gl->LoadMatrixf(m);
}

static void setup_lights(const GlApi *gl, const Scene *s)
{
    float amb[4] = {s->ambient.x, s->ambient.y, s->ambient.z, 1.0f};
    gl->LightModelfv(GL_LIGHT_MODEL_AMBIENT, amb);
    gl->LightModeli(GL_LIGHT_MODEL_LOCAL_VIEWER, GL_TRUE);
    gl->LightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_TRUE);
    float zero[4] = {0, 0, 0, 1};
    /* GL guarantees 8 lights; further ones are not shown in the preview. */
    for (int k = 0; k < 8; k++) {
        GLenum id = (GLenum)(GL_LIGHT0 + k);
        if (k >= s->num_lights) {
            gl->Disable(id);
            continue;
        }
        const Light *l = &s->lights[k];
        float col[4] = {l->color.x, l->color.y, l->color.z, 1.0f};
        float pos[4];
        if (l->kind == LIGHT_DIRECTIONAL) {
            /* w = 0: a direction TOWARD the light. */
            pos[0] = -l->direction.x;
            pos[1] = -l->direction.y;
            pos[2] = -l->direction.z;
            pos[3] = 0.0f;
        } else {
            pos[0] = l->position.x;
            pos[1] = l->position.y;
            pos[2] = l->position.z;
            pos[3] = 1.0f;
        }
        gl->Lightfv(id, GL_POSITION, pos);
        gl->Lightfv(id, GL_AMBIENT, zero);
        gl->Lightfv(id, GL_DIFFUSE, col);
        gl->Lightfv(id, GL_SPECULAR, col);
        bool point = l->kind == LIGHT_POINT;
        gl->Lightf(id, GL_CONSTANT_ATTENUATION, point ? l->attenuation[0] : 1.0f);
        gl->Lightf(id, GL_LINEAR_ATTENUATION, point ? l->attenuation[1] : 0.0f);
        gl->Lightf(id, GL_QUADRATIC_ATTENUATION, point ? l->attenuation[2] : 0.0f);
        gl->Enable(id);
    }
}

/* ---- grid (course Grid::paint and the RayTree cell displays) ---- */

typedef struct GridGeom {
    const Grid *g;
    int n[3];
    Vec3 min, size;   /* cell size */
} GridGeom;

static Vec3 cell_corner(const GridGeom *gg, int i, int j, int k)
{
    return v3(gg->min.x + (float)i * gg->size.x, gg->min.y + (float)j * gg->size.y,
              gg->min.z + (float)k * gg->size.z);
}

static bool cell_occupied(const GridGeom *gg, int i, int j, int k)
{
    if (i < 0 || j < 0 || k < 0 || i >= gg->n[0] || j >= gg->n[1] || k >= gg->n[2])
        return false;
    return grid_cell_count(gg->g, i, j, k) > 0;
}

/* Face f of a cell: axis f/2, side f%2 (0 = min side). */
static void cell_face(const GlApi *gl, const GridGeom *gg, int i, int j, int k, int f)
{
    int axis = f / 2, side = f % 2;
    Vec3 lo = cell_corner(gg, i, j, k), hi = cell_corner(gg, i + 1, j + 1, k + 1);
    float n[3] = {0, 0, 0};
    n[axis] = side ? 1.0f : -1.0f;
    gl->Normal3f(n[0], n[1], n[2]);
    int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    float fixed = side ? v3_comp(hi, axis) : v3_comp(lo, axis);
    float lo1 = v3_comp(lo, a1), hi1 = v3_comp(hi, a1);
    float lo2 = v3_comp(lo, a2), hi2 = v3_comp(hi, a2);
    float q[4][2] = {{lo1, lo2}, {hi1, lo2}, {hi1, hi2}, {lo1, hi2}};
    for (int c = 0; c < 4; c++) {
        float p[3];
        p[axis] = fixed;
        p[a1] = q[c][0];
        p[a2] = q[c][1];
        gl->Vertex3f(p[0], p[1], p[2]);
    }
}

static void set_palette(DrawCtx *d, int count)
{
    PhongParams p;
    if (!phong_params(grid_palette_material(count), &p))
        p = phong_defaults();
    set_diffuse_only(d, p.diffuse);
}

static void draw_occupied_cells(DrawCtx *d, const GridGeom *gg)
{
    const GlApi *gl = d->gl;
    int last = -1;
    gl->Begin(GL_QUADS);
    for (int i = 0; i < gg->n[0]; i++)
        for (int j = 0; j < gg->n[1]; j++)
            for (int k = 0; k < gg->n[2]; k++) {
                int count = grid_cell_count(gg->g, i, j, k);
                if (count <= 0)
                    continue;
                if (count != last) {
                    gl->End();
                    set_palette(d, count);
                    gl->Begin(GL_QUADS);
                    last = count;
                }
                /* Faces shared with an occupied neighbour are hidden: skip them. */
                for (int f = 0; f < 6; f++) {
                    int di = f / 2 == 0 ? (f % 2 ? 1 : -1) : 0;
                    int dj = f / 2 == 1 ? (f % 2 ? 1 : -1) : 0;
                    int dk = f / 2 == 2 ? (f % 2 ? 1 : -1) : 0;
                    if (!cell_occupied(gg, i + di, j + dj, k + dk))
                        cell_face(gl, gg, i, j, k, f);
                }
            }
    gl->End();
}

static void cell_edges(const GlApi *gl, Vec3 lo, Vec3 hi)
{
    for (int axis = 0; axis < 3; axis++) {
        int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
        for (int e = 0; e < 4; e++) {
            float p[3], q[3];
            p[axis] = v3_comp(lo, axis);
            q[axis] = v3_comp(hi, axis);
            p[a1] = q[a1] = (e & 1) ? v3_comp(hi, a1) : v3_comp(lo, a1);
            p[a2] = q[a2] = (e & 2) ? v3_comp(hi, a2) : v3_comp(lo, a2);
            gl->Vertex3f(p[0], p[1], p[2]);
            gl->Vertex3f(q[0], q[1], q[2]);
        }
    }
}

static bool cell_valid(const GridGeom *gg, const RayTreeCell *c)
{
    return c->i >= 0 && c->j >= 0 && c->k >= 0 && c->i < gg->n[0] && c->j < gg->n[1] &&
           c->k < gg->n[2];
}

static void draw_grid(DrawCtx *d, const Grid *g)
{
    const GlApi *gl = d->gl;
    const PreviewView *v = d->v;
    GridGeom gg;
    gg.g = g;
    grid_dims(g, gg.n);
    BBox b = grid_bounds(g);
    gg.min = b.min;
    gg.size = v3((b.max.x - b.min.x) / (float)gg.n[0], (b.max.y - b.min.y) / (float)gg.n[1],
                 (b.max.z - b.min.z) / (float)gg.n[2]);
    const RayTree *t = v->has_tree ? v->tree : NULL;

    if (v->mode == PREVIEW_GRID) {
        draw_occupied_cells(d, &gg);
    } else if (t) {
        /* Visited cells: occupied ones solid in their palette colour. */
        gl->Begin(GL_QUADS);
        for (int c = 0; c < t->num_cells; c++) {
            const RayTreeCell *rc = &t->cells[c];
            if (!cell_valid(&gg, rc))
                continue;
            int count = grid_cell_count(g, rc->i, rc->j, rc->k);
            if (count <= 0)
                continue;
            gl->End();
            set_palette(d, count);
            gl->Begin(GL_QUADS);
            for (int f = 0; f < 6; f++)
                cell_face(gl, &gg, rc->i, rc->j, rc->k, f);
        }
        gl->End();
    }

    gl->Disable(GL_LIGHTING);
    /* The grid box: white wireframe. */
    gl->LineWidth(1.0f);
    gl->Color3f(1, 1, 1);
    gl->Begin(GL_LINES);
    cell_edges(gl, b.min, b.max);
    gl->End();
    if (t) {
        gl->Enable(GL_BLEND);
        gl->BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
        gl->DepthMask(GL_FALSE);
        if (v->mode == PREVIEW_GRID_RAY) {
            /* The face each visited cell was entered through (course AddEnteredFace). */
            gl->Color4f(1.0f, 1.0f, 0.2f, 0.6f);
            gl->Begin(GL_QUADS);
            for (int c = 0; c < t->num_cells; c++) {
                const RayTreeCell *rc = &t->cells[c];
                Vec3 en = rc->entered_normal;
                if (!cell_valid(&gg, rc) || v3_is_zero(en))
                    continue;
                int axis = fabsf(en.x) > 0.5f ? 0 : fabsf(en.y) > 0.5f ? 1 : 2;
                int side = v3_comp(en, axis) > 0.0f ? 1 : 0;
                cell_face(gl, &gg, rc->i, rc->j, rc->k, axis * 2 + side);
            }
            gl->End();
        }
        /* Visited cells outlined in yellow, visible through the cubes. */
        gl->Disable(GL_DEPTH_TEST);
        gl->Color4f(1.0f, 0.9f, 0.1f, 0.8f);
        gl->Begin(GL_LINES);
        for (int c = 0; c < t->num_cells; c++) {
            const RayTreeCell *rc = &t->cells[c];
            if (cell_valid(&gg, rc))
                cell_edges(gl, cell_corner(&gg, rc->i, rc->j, rc->k),
                           cell_corner(&gg, rc->i + 1, rc->j + 1, rc->k + 1));
        }
        gl->End();
        gl->Enable(GL_DEPTH_TEST);
        gl->DepthMask(GL_TRUE);
        gl->Disable(GL_BLEND);
    }
    gl->Enable(GL_LIGHTING);
}

/* ---- ray tree (course RayTree::paint) ---- */

static void seg_color(const GlApi *gl, RaySegKind k, float alpha)
{
    switch (k) {
    case RAYSEG_MAIN:        gl->Color4f(0.7f, 0.7f, 0.7f, alpha); break;
    case RAYSEG_SHADOW:      gl->Color4f(0.1f, 0.9f, 0.1f, alpha); break;
    case RAYSEG_REFLECTED:   gl->Color4f(0.9f, 0.1f, 0.1f, alpha); break;
    case RAYSEG_TRANSMITTED: gl->Color4f(0.1f, 0.1f, 0.9f, alpha); break;
    }
}

static void draw_tree_segments(const GlApi *gl, const RayTree *t, float alpha)
{
    gl->Begin(GL_LINES);
    for (int s = 0; s < t->num_segments; s++) {
        const RaySegment *seg = &t->segments[s];
        seg_color(gl, seg->kind, alpha);
        vertex(gl, seg->a);
        vertex(gl, seg->b);
    }
    gl->End();
}

static void draw_tree(const GlApi *gl, const RayTree *t)
{
    gl->Disable(GL_LIGHTING);
    gl->LineWidth(2.0f);
    /* Twice, as the course: translucent through everything, then solid where visible. */
    gl->Enable(GL_BLEND);
    gl->BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    gl->Disable(GL_DEPTH_TEST);
    draw_tree_segments(gl, t, 0.3f);
    gl->Disable(GL_BLEND);
    gl->Enable(GL_DEPTH_TEST);
    draw_tree_segments(gl, t, 1.0f);
    gl->LineWidth(1.0f);
    gl->Enable(GL_LIGHTING);
}

static void draw_traced(const GlApi *gl, const PreviewTraced *tr, int w, int h)
{
    if (!tr || tr->image.width != w || tr->image.height != h)
        return;
    gl->MatrixMode(GL_PROJECTION);
    gl->LoadIdentity();
    gl->Ortho(0, w, 0, h, -1, 1);
    gl->MatrixMode(GL_MODELVIEW);
    gl->LoadIdentity();
    gl->Disable(GL_LIGHTING);
    gl->Disable(GL_DEPTH_TEST);
    gl->PixelStorei(GL_UNPACK_ALIGNMENT, 1);
    for (int y = 0; y < h; y++) {
        if (!atomic_load_explicit(&tr->row_ready[y], memory_order_acquire))
            continue;
        /* A quarter pixel inside so the raster position is never clipped. */
        gl->RasterPos2f(0.25f, (float)y + 0.25f);
        gl->DrawPixels(w, 1, GL_RGB, GL_FLOAT, &tr->image.pixels[(long)y * w]);
    }
    gl->Enable(GL_DEPTH_TEST);
    gl->Enable(GL_LIGHTING);
}

void preview_draw_frame(const GlApi *gl, const PreviewView *v, int w, int h,
                        const PreviewTraced *traced)
{
    const Scene *s = v->cfg->scene;
    const Grid *grid = preview_view_grid(v);
    gl->Viewport(0, 0, w, h);
    gl->ClearColor(s->background.x, s->background.y, s->background.z, 1.0f);
    gl->Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    /* The course GLCanvas's state: depth test, smooth shading. */
    gl->Enable(GL_DEPTH_TEST);
    gl->ShadeModel(GL_SMOOTH);
    gl->Enable(GL_LIGHTING);
    gl->Disable(GL_CULL_FACE);
    gl->Enable(GL_NORMALIZE);
    gl->Disable(GL_BLEND);

    setup_camera(gl, &v->camera, &s->bounds, w, h);
    setup_lights(gl, s);

    DrawCtx d = {gl, v, NULL};
    if (v->mode != PREVIEW_OBJECTS && grid) {
        draw_grid(&d, grid);
    } else if (s->root) {
        bool in_tris = false;
        draw_object(&d, s->root, &in_tris);
        end_tris(&d, &in_tris);
    }
    if (v->has_tree)
        draw_tree(gl, v->tree);
    draw_traced(gl, traced, w, h);
    gl->Finish();
}

void preview_read_frame(const GlApi *gl, int w, int h, Image *img, unsigned char *scratch)
{
    gl->PixelStorei(GL_PACK_ALIGNMENT, 1);
    gl->ReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, scratch);
    for (long p = 0; p < (long)w * h; p++) {
        const unsigned char *b = &scratch[p * 3];
        img->pixels[p] = v3(((float)b[0] + 0.5f) / 255.0f, ((float)b[1] + 0.5f) / 255.0f,
                            ((float)b[2] + 0.5f) / 255.0f);
    }
}
#else
typedef int rt_preview_draw_unused; /* keeps the translation unit non-empty */
#endif
