/* Fuzz target: the scene parser on raw bytes with their length, then the whole scene as
 * the program uses it: built into a grid (its resolution taken from the input, up to
 * 64 per side, or -grid auto) and rendered at 4x4 pixels with shadows and bounces, with
 * and without the grid. The grid sizes reach the region where too many cell references
 * once blew up time and memory (many large objects in a fine grid). */
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "fuzz_models.h"
#include "rt/grid.h"
#include "rt/image.h"
#include "rt/render.h"
#include "rt/scene.h"

static const char *g_dir;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    g_dir = fuzz_models_setup();
    if (!g_dir)
        abort(); /* set-up of the harness itself, not an input */
    return 0;
}

static void render_tiny(const Scene *s, const Accel *a)
{
    RayTracer rt;
    memset(&rt, 0, sizeof rt);
    rt.scene = s;
    rt.accel = a;
    rt.shadows = true;
    rt.shade_back = true;
    rt.bounces = 3;
    rt.weight = 0.01f;
    Image color, depth, normals;
    if (!image_init(&color, 4, 4))
        return;
    if (!image_init(&depth, 4, 4)) {
        image_free(&color);
        return;
    }
    if (!image_init(&normals, 4, 4)) {
        image_free(&color);
        image_free(&depth);
        return;
    }
    RenderTarget t;
    memset(&t, 0, sizeof t);
    t.width = t.height = 4;
    t.color = &color;
    t.depth = &depth;
    t.normals = &normals;
    t.depth_min = 0.0f;
    t.depth_max = 20.0f;
    RtStats st;
    render_image(&rt, &s->camera, &t, 1, &st, NULL, NULL, NULL);
    image_free(&color);
    image_free(&depth);
    image_free(&normals);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Diag d;
    diag_init(&d, NULL);
    Scene *s = scene_load_buffer((const char *)data, size, "fuzz.txt", g_dir, &d);
    if (!s)
        return 0;
    if (s->has_camera && s->root) {
        /* The grid resolution from the input's size and last byte: stable per input. */
        unsigned h = (unsigned)size * 2654435761u ^ (size ? data[size - 1] : 0u);
        AccelConfig cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.grid_n[0] = 1 + (int)(h % 64);
        cfg.grid_n[1] = 1 + (int)((h >> 6) % 64);
        cfg.grid_n[2] = 1 + (int)((h >> 12) % 64);
        cfg.grid_auto = (h & 0x40000) != 0;
        PrimTable t;
        if (prim_table_build(&t, s)) {
            /* Every registered accelerator, the grid also as its visualisation. */
            for (int i = 0; accel_registry[i]; i++) {
                Accel a;
                cfg.visualize = (h >> 19) & 1;
                if (accel_init(&a, accel_registry[i], &t, &cfg, &d)) {
                    render_tiny(s, &a);
                    accel_free(&a);
                }
            }
            prim_table_free(&t);
        }
    }
    scene_free(s);
    return 0;
}
