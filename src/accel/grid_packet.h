/* Private state of the packet traversal (grid_packet.c): rays in SIMD-friendly columns
 * of PK_LANES, shared by the generic kernel and the AVX2 build of the same kernel
 * (grid_packet_kernel.h, compiled twice). */
#ifndef RT_ACCEL_GRID_PACKET_H
#define RT_ACCEL_GRID_PACKET_H

#include <stdint.h>
#include "grid_internal.h"

#define PK_LANES 8
#define PK_GROUPS (GRID_PACKET_MAX / PK_LANES)

/* GCC/Clang vector extensions: 8 lanes; the compiler maps them to one AVX register or
 * two SSE registers. Arithmetic on them is lane-wise IEEE, like the scalar code. */
typedef float pk_f8 __attribute__((vector_size(32)));
typedef int32_t pk_i8 __attribute__((vector_size(32)));
typedef uint32_t pk_u8 __attribute__((vector_size(32)));

/* An untransformed plane among the grid's unbounded primitives, tested by the packet's
 * set-up lane by lane with plane_intersect's arithmetic (grid_packet.c fills them). */
typedef struct PacketPlane {
    float n[3], offset;     /* the normal as given and the offset */
    uint32_t id;
} PacketPlane;

/* The most unbounded primitives the set-up tests itself; with more, or with any that is
 * not an untransformed plane, each ray tests them through its ops before the set-up. */
#define PK_MAX_PLANES 4

typedef struct Packet {
    _Alignas(64) pk_f8 o[3][PK_GROUPS]; /* 64-aligned: the 16-lane kernel reads */
    pk_f8 d[3][PK_GROUPS];
    pk_f8 inv_k[PK_GROUPS];     /* 1 / d[axis] */
    pk_f8 t0[PK_GROUPS];        /* where the ray's part inside the padded box starts (>= tmin) */
    pk_f8 t1[PK_GROUPS];        /* ... and ends (shadow rays: also < tmax) */
    pk_f8 best_t[PK_GROUPS];    /* nearest: t of the best hit so far; shadow: tmax */
    pk_u8 best_id[PK_GROUPS];   /* nearest: its id */
    pk_i8 best_prim[PK_GROUPS]; /* nearest: packed primitive of the best hit; -1: the
                                   caller's Hit holds the best hit; -2 - u: planes[u] */
    /* Set-up per ray (grid_packet.c): the ends of its part in the box across the main
     * axis (u, v at t0 and at t1) and the slice it starts in, for splitting. */
    float end[4][GRID_PACKET_MAX];
    int k_start[GRID_PACKET_MAX];
    uint64_t active;            /* rays still walking */
    uint64_t hit;               /* nearest: rays with a hit; shadow: rays occluded */
    int axis, sign, k_first;    /* main axis, its direction (+1/-1), first slice */
    float tmin;
    float march_tmin;           /* grid_march_tmin(tmin): where the walk starts */
    bool shadow;
    /* Shadow rays towards a directional light (grid_occluded_packet_dir): every ray
     * has direction dir and tmax same_tmax; the rays' own directions are not read. */
    bool same_dir;
    float dir[3];
    float same_tmax;
    int num_planes;             /* planes the set-up tests (0: none, or done per ray) */
    PacketPlane planes[PK_MAX_PLANES];
    Hit *hits;                  /* nearest: the caller's hits */
    const Ray *rays;
    /* The rays of xf_lanes carried through the transform chain xf (the first step of
     * every test of a leaf below it: transform_path_to_object), kept for the leaf after:
     * the leaves of one mesh under a Transform share a chain. NULL: none yet. */
    const PrimXform *xf;
    uint64_t xf_lanes;
    Ray xf_ray[GRID_PACKET_MAX];
    float xf_tmin[GRID_PACKET_MAX];
} Packet;

/* Ray i of the packet as the single-ray code takes it (with same_dir, its origin and
 * the shared direction). */
static inline Ray packet_ray(const Packet *pk, int i)
{
    Ray r;
    r.origin = pk->rays[i].origin;
    r.dir = pk->same_dir ? v3(pk->dir[0], pk->dir[1], pk->dir[2]) : pk->rays[i].dir;
    return r;
}

/* Packet marking: which of a packet's rays have tested a primitive. A direct-mapped
 * table of the thread (16 KB, so it stays in the first-level cache), slot prim mod
 * PK_MARK_SLOTS, valid for the walk whose generation it carries. A slot taken over by
 * another primitive only forgets marks, and a forgotten mark costs a repeated test with
 * the same answer (the same t and id, which hit_accepts does not take twice); the per-
 * primitive arrays it replaces (12 bytes a primitive: 16 MB on a 1.3M-triangle mesh,
 * read at every entry) made most entries a cache miss. */
#define PK_MARK_SLOTS 1024
typedef struct PacketMark {
    uint32_t gen;               /* the walk that wrote it (0: none yet) */
    uint32_t prim;
    uint64_t rays;              /* that walk's rays that have tested prim */
} PacketMark;
typedef struct PacketMarks {
    uint32_t gen;
    PacketMark slot[PK_MARK_SLOTS];
} PacketMarks;
/* This thread's table with a fresh generation (grid_packet.c). */
PacketMarks *grid_packet_marks(void);

/* One kernel per instruction set: walks the packet's active rays (grid_packet_kernel.h). */
void grid_packet_walk_generic(const Grid *g, Packet *pk, RenderCtx *ctx);
void grid_packet_walk_avx2(const Grid *g, Packet *pk, RenderCtx *ctx);
void grid_packet_walk_avx512(const Grid *g, Packet *pk, RenderCtx *ctx);
void grid_packet_walk_avx512x8(const Grid *g, Packet *pk, RenderCtx *ctx);
/* ... and its per-ray set-up (grid_packet_kernel.h, PK_PREP). */
uint64_t grid_packet_prep_generic(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                                  uint64_t *single_out);
uint64_t grid_packet_prep_avx2(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                               uint64_t *single_out);
uint64_t grid_packet_prep_avx512(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                                 uint64_t *single_out);
uint64_t grid_packet_prep_avx512x8(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                                   uint64_t *single_out);
/* ... and the width of a packet's rays in cells (PK_SPREAD). */
float grid_packet_spread_generic(const Grid *g, const Packet *pk, uint64_t walk);
float grid_packet_spread_avx2(const Grid *g, const Packet *pk, uint64_t walk);
float grid_packet_spread_avx512(const Grid *g, const Packet *pk, uint64_t walk);
float grid_packet_spread_avx512x8(const Grid *g, const Packet *pk, uint64_t walk);

#endif
