/* Fuzz target: -gui_keys scripts (bytes up to the first NUL), parsed and applied to the
 * preview's view of a small scene (traces, grid modes, camera moves), as the window
 * and the snapshot do minus the GL drawing. */
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "fuzz_models.h"
#include "../../src/preview/view.h"
#include "rt/grid.h"
#include "rt/image.h"
#include "rt/raytracer.h"
#include "rt/render.h"
#include "rt/scene.h"

static const char SCENE[] =
    "PerspectiveCamera { center 0 1 8 direction 0 -0.1 -1 up 0 1 0 angle 40 }\n"
    "Lights { numLights 1 PointLight { position 2 4 4 color 1 1 1 } }\n"
    "Background { color 0.1 0.1 0.2 ambientLight 0.1 0.1 0.1 }\n"
    "Materials { numMaterials 2\n"
    "  PhongMaterial { diffuseColor 0.8 0.2 0.2 reflectiveColor 0.3 0.3 0.3 }\n"
    "  PhongMaterial { diffuseColor 0.2 0.8 0.2 transparentColor 0.5 0.5 0.5 indexOfRefraction 1.5 } }\n"
    "Group { numObjects 4\n"
    "  MaterialIndex 0 Sphere { center 0 0 0 radius 1 }\n"
    "  MaterialIndex 1 Sphere { center 1.5 0 0 radius 0.5 }\n"
    "  Plane { normal 0 1 0 offset -1 }\n"
    "  Transform { Translate -2 0 0 TriangleMesh { obj_file cube.obj } } }\n";

static Scene *g_scene;
static PrimTable g_prims;
static Accel g_accel;
static RayTracer g_rt;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *dir = fuzz_models_setup();
    Diag d;
    diag_init(&d, NULL);
    g_scene = dir ? scene_load_string(SCENE, "keys.txt", dir, &d) : NULL;
    if (!g_scene)
        abort(); /* the harness's own scene */
    AccelConfig cfg = {.grid_n = {6, 6, 6}, .grid_auto = false, .no_marking = false, .visualize = false};
    if (!prim_table_build(&g_prims, g_scene) ||
        !accel_init(&g_accel, accel_find("grid"), &g_prims, &cfg, &d))
        abort(); /* the harness's own scene */
    memset(&g_rt, 0, sizeof g_rt);
    g_rt.scene = g_scene;
    g_rt.accel = &g_accel;
    g_rt.shadows = true;
    g_rt.bounces = 4;
    return 0;
}

/* `r`: the moved camera's view, ray traced small (the window renders at -size). */
static void render_view(const PreviewView *v)
{
    Image img;
    if (!image_init(&img, 6, 4))
        return;
    RenderTarget t;
    memset(&t, 0, sizeof t);
    t.width = 6;
    t.height = 4;
    t.color = &img;
    render_image(&g_rt, &v->camera, &t, 1, NULL, NULL, NULL, NULL);
    image_free(&img);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = malloc(size + 1);
    if (!text)
        return 0;
    memcpy(text, data, size);
    text[size] = '\0';
    Diag d;
    diag_init(&d, NULL);
    KeyScript ks;
    if (preview_keys_parse(text, &ks, &d)) {
        PreviewConfig cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.scene = g_scene;
        cfg.tracer = &g_rt;
        cfg.width = 16;
        cfg.height = 12;
        cfg.tess_theta = 8;
        cfg.tess_phi = 4;
        cfg.threads = 1;
        PreviewView v;
        if (preview_view_init(&v, &cfg, &d)) {
            FILE *null = fopen("/dev/null", "w");
            for (int i = 0; i < ks.count && null; i++) {
                const KeyCmd *c = &ks.cmds[i];
                bool ok = true;
                if (c->kind == KEYCMD_GRID)
                    preview_view_cycle_grid(&v, null);
                else if (c->kind == KEYCMD_CAMERA)
                    preview_view_print_camera(&v, null);
                else if (c->kind == KEYCMD_RENDER)
                    render_view(&v);
                else
                    preview_view_apply(&v, c, cfg.width, cfg.height, &ok);
            }
            if (null)
                fclose(null);
            preview_view_free(&v);
        }
        preview_keys_free(&ks);
    }
    free(text);
    return 0;
}
