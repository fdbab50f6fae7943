/* Per-thread render context: everything a method may write while the scene is shared
 * read-only between threads (statistics, grid marking stamps, ray-tree recording). */
#ifndef RT_RENDER_CTX_H
#define RT_RENDER_CTX_H

#include <stdint.h>
#include "rt/stats.h"
#include "rt/ray_tree.h"

typedef struct RenderCtx {
    RtStats stats;
    uint32_t *mailbox;     /* grid marking: one stamp per grid entry-primitive, or NULL */
    uint32_t num_mailbox;  /* entries in mailbox */
    uint32_t ray_stamp;    /* stamp of the ray being marched (0 is never a live stamp) */
    uint64_t *packet_rays; /* non-NULL: packet traversal on (raytracer_ctx_init makes one
                              mask; the packets mark in a table of their own, in
                              src/accel/grid_packet.h); NULL: grid_*_packet go ray by ray */
    RayTree *tree;         /* non-NULL only while the GUI records one ray tree */
    volatile int *cancel;  /* the run's stop flag (render_parallel sets it), or NULL: once
                              non-zero no reflected or refracted ray is spawned, so one
                              pixel's huge ray tree cannot delay a stop; the run's images
                              are discarded then, so no byte of a finished run changes */
} RenderCtx;

#endif
