/* The body of one lane kernel of perlin_octaves_lanes (perlin.c): perlin_octaves at
 * PL_W points at once, one point per lane, for one instruction set. Included once per
 * kernel by perlin.c after it has defined, for that set, PL_W, the name PL_FN, the
 * function attribute PL_TARGET, the vector types PL_D (PL_W doubles) and PL_I (PL_W
 * 32-bit ints) and the suffix macro PL_(name) naming its primitives: d_set, d_load,
 * d_store, d_add, d_sub, d_mul, d_neg (the sign bit flipped), d_floor, d_lane0 (lane
 * 0's value), d_one_cell (whether every lane's three floors equal lane 0's),
 * d_zero_unless_small (the lanes whose |floor| is not below 1e9 set to +0), i_trunc,
 * i_set, i_add, i_and, i_perm2 (the word at byte i & 255 of the table: P[i & 255] in
 * byte 0, P[(i + 1) & 255] in byte 1), i_byte0, i_byte1 and grad (of the hash's low
 * four bits). A kernel with PL_OWN_NOISE defines its own noise (PL_(noise), given the
 * floors) and then needs none of the i_ primitives nor grad and d_zero_unless_small.
 *
 * Lane by lane every value is the operation noise3_scalar and perlin_octaves apply, on
 * the same operands in the same order (floor, the subtraction of the cell, the quintic
 * fade in Horner form, the hashes, the gradients by selection and sign flips, the
 * seven lerps, the octave's scaling and sum), each a single IEEE double operation;
 * nothing is fused (perlin.c is built with -ffp-contract=off). So each lane gives
 * perlin_octaves' bits; tests/unit/test_perlin.c holds every kernel to it.
 *
 * A vector whose lanes all lie in one lattice cell (the samples of one pixel or of
 * neighbouring pixels: on course line 17a at 400 x 400 with 16 samples, 87% of the
 * vectors at the coarsest of its 5 octaves, 47% at the finest) takes noise_cell: the
 * eight corner hashes are the same in every lane, so they are looked up once, in
 * scalar code (cell_picks, or taken from the previous vector's when it lay in the
 * same cell at that octave), and each corner's gradient is two whole vectors added,
 * picked by the hash (cell_off, from CELL_U and CELL_V) from the distances and their negations: the values
 * grad selects and sign-flips lane by lane, so the same bits again. */

#ifndef PL_MEMO_OCTAVES
#define PL_MEMO_OCTAVES 8 /* octaves whose last cell PL_FN remembers (the course's: 1-5) */
#endif

PL_TARGET static inline PL_D PL_(fade)(PL_D t)
{
    PL_D t3 = PL_(d_mul)(PL_(d_mul)(t, t), t);
    PL_D in = PL_(d_sub)(PL_(d_mul)(t, PL_(d_set)(6.0)), PL_(d_set)(15.0));
    return PL_(d_mul)(t3, PL_(d_add)(PL_(d_mul)(t, in), PL_(d_set)(10.0)));
}

PL_TARGET static inline PL_D PL_(lerp)(PL_D t, PL_D a, PL_D b)
{
    return PL_(d_add)(a, PL_(d_mul)(t, PL_(d_sub)(b, a)));
}

#ifndef PL_OWN_NOISE
/* fx, fy, fz: the floors of x, y, z (the caller has them for its cell test). */
PL_TARGET static inline PL_D PL_(noise)(PL_D x, PL_D y, PL_D z, PL_D fx, PL_D fy, PL_D fz)
{
    PL_I m255 = PL_(i_set)(255);
    PL_I X = PL_(i_and)(PL_(i_trunc)(fx), m255), Y = PL_(i_and)(PL_(i_trunc)(fy), m255),
         Z = PL_(i_and)(PL_(i_trunc)(fz), m255);
    PL_D one = PL_(d_set)(1.0);
    PL_D x0 = PL_(d_sub)(x, fx), y0 = PL_(d_sub)(y, fy), z0 = PL_(d_sub)(z, fz);
    PL_D u = PL_(fade)(x0), v = PL_(fade)(y0), w = PL_(fade)(z0);
    /* Each gather gives perm(i) and perm(i + 1) (i_perm2): A, B from X; AA, AB from A;
     * BA, BB from B; then the corner hashes perm(AA), perm(AA + 1) and so on. */
    PL_I px = PL_(i_perm2)(X);
    PL_I A = PL_(i_add)(PL_(i_byte0)(px), Y), B = PL_(i_add)(PL_(i_byte1)(px), Y);
    PL_I pa = PL_(i_perm2)(A), pb = PL_(i_perm2)(B);
    PL_I AA = PL_(i_add)(PL_(i_byte0)(pa), Z), AB = PL_(i_add)(PL_(i_byte1)(pa), Z);
    PL_I BA = PL_(i_add)(PL_(i_byte0)(pb), Z), BB = PL_(i_add)(PL_(i_byte1)(pb), Z);
    PL_I haa = PL_(i_perm2)(AA), hab = PL_(i_perm2)(AB), hba = PL_(i_perm2)(BA),
         hbb = PL_(i_perm2)(BB);
    PL_D x1 = PL_(d_sub)(x0, one), y1 = PL_(d_sub)(y0, one), z1 = PL_(d_sub)(z0, one);
    /* grad uses the hash's low four bits only: no byte mask needed for byte 0. */
    PL_D g000 = PL_(grad)(haa, x0, y0, z0);
    PL_D g100 = PL_(grad)(hba, x1, y0, z0);
    PL_D g010 = PL_(grad)(hab, x0, y1, z0);
    PL_D g110 = PL_(grad)(hbb, x1, y1, z0);
    PL_D g001 = PL_(grad)(PL_(i_byte1)(haa), x0, y0, z1);
    PL_D g101 = PL_(grad)(PL_(i_byte1)(hba), x1, y0, z1);
    PL_D g011 = PL_(grad)(PL_(i_byte1)(hab), x0, y1, z1);
    PL_D g111 = PL_(grad)(PL_(i_byte1)(hbb), x1, y1, z1);
    PL_D r = PL_(lerp)(w,
                       PL_(lerp)(v, PL_(lerp)(u, g000, g100), PL_(lerp)(u, g010, g110)),
                       PL_(lerp)(v, PL_(lerp)(u, g001, g101), PL_(lerp)(u, g011, g111)));
    /* The cells too far out for the int conversion (or not finite): 0, as the scalar
     * code returns before computing anything (the lanes' garbage is dropped here). */
    return PL_(d_zero_unless_small)(r, fx, fy, fz);
}
#endif

/* CELL_U and CELL_V (perlin.c) as byte offsets into noise_cell's d (index times the
 * vector's size): for hash h and corner c, u's offset at [h][c] and v's at [h][8 + c].
 * With them a corner's gradient is two loads at offsets read straight from the picks:
 * both offsets packed in one word (u's in the low 16 bits) took a shift and a
 * zero-extension each, about a fifth of noise_cell's instructions (callgrind, course
 * line 17a with 16 jittered samples: 127 per vector and octave then); before that, a
 * table of the two indices as nibbles took a mask or shift and a scaling per index, in
 * a loop that stored its eight sums to memory. */
#define PL_OFF_U(h, c) (uint32_t)(CELL_U(h, (c)&1, (c) >> 1 & 1) * sizeof(PL_D))
#define PL_OFF_V(h, c) (uint32_t)(CELL_V(h, (c)&1, (c) >> 1 & 1, (c) >> 2) * sizeof(PL_D))
#define PL_OFF_ROW(h)                                                                        \
    {PL_OFF_U(h, 0), PL_OFF_U(h, 1), PL_OFF_U(h, 2), PL_OFF_U(h, 3),                        \
     PL_OFF_U(h, 4), PL_OFF_U(h, 5), PL_OFF_U(h, 6), PL_OFF_U(h, 7),                        \
     PL_OFF_V(h, 0), PL_OFF_V(h, 1), PL_OFF_V(h, 2), PL_OFF_V(h, 3),                        \
     PL_OFF_V(h, 4), PL_OFF_V(h, 5), PL_OFF_V(h, 6), PL_OFF_V(h, 7)}
static const uint32_t PL_(cell_off)[16][16] = {
    PL_OFF_ROW(0),  PL_OFF_ROW(1),  PL_OFF_ROW(2),  PL_OFF_ROW(3),  PL_OFF_ROW(4),
    PL_OFF_ROW(5),  PL_OFF_ROW(6),  PL_OFF_ROW(7),  PL_OFF_ROW(8),  PL_OFF_ROW(9),
    PL_OFF_ROW(10), PL_OFF_ROW(11), PL_OFF_ROW(12), PL_OFF_ROW(13), PL_OFF_ROW(14),
    PL_OFF_ROW(15),
};
#undef PL_OFF_ROW
#undef PL_OFF_V
#undef PL_OFF_U

/* The picks of the cell with floors fx0, fy0, fz0 (each below 1e9 in magnitude): the
 * cell's corner hashes as noise3_scalar computes them, each as its cell_off entries
 * (the two d offsets, see noise_cell) for its corner: u's in pick[c], v's in
 * pick[8 + c]. */
PL_TARGET static inline void PL_(cell_picks)(double fx0, double fy0, double fz0,
                                             uint32_t pick[16])
{
    int X = (int)fx0 & 255, Y = (int)fy0 & 255, Z = (int)fz0 & 255;
    int A = perm(X) + Y, AA = perm(A) + Z, AB = perm(A + 1) + Z;
    int B = perm(X + 1) + Y, BA = perm(B) + Z, BB = perm(B + 1) + Z;
    /* Corner c = i + 2j + 4k: its hash picks its u and v. */
#define PL_PICK(c, hash)                                                                     \
    do {                                                                                     \
        const uint32_t *row = PL_(cell_off)[(hash)&15];                                      \
        pick[c] = row[c];                                                                    \
        pick[8 + (c)] = row[8 + (c)];                                                        \
    } while (0)
    PL_PICK(0, perm(AA));
    PL_PICK(1, perm(BA));
    PL_PICK(2, perm(AB));
    PL_PICK(3, perm(BB));
    PL_PICK(4, perm(AA + 1));
    PL_PICK(5, perm(BA + 1));
    PL_PICK(6, perm(AB + 1));
    PL_PICK(7, perm(BB + 1));
#undef PL_PICK
}

/* noise where every lane lies in the cell of floors fx, fy, fz whose picks are pick
 * (cell_picks; no lane answers 0): the distances, fades and lerps as noise. d holds
 * the six distances and their negations at the indices CELL_U and CELL_V give (axis * 4 +
 * corner bit * 2 + negated); pick[c] and pick[8 + c] hold corner c's byte offsets into
 * d of u and of v (the sum u + v in grad's order). */
PL_TARGET static inline PL_D PL_(noise_cell)(PL_D x, PL_D y, PL_D z, PL_D fx, PL_D fy, PL_D fz,
                                             const uint32_t pick[16])
{
    PL_D one = PL_(d_set)(1.0);
    PL_D x0 = PL_(d_sub)(x, fx), y0 = PL_(d_sub)(y, fy), z0 = PL_(d_sub)(z, fz);
    PL_D u = PL_(fade)(x0), v = PL_(fade)(y0), w = PL_(fade)(z0);
    PL_D x1 = PL_(d_sub)(x0, one), y1 = PL_(d_sub)(y0, one), z1 = PL_(d_sub)(z0, one);
    PL_D d[12] = {x0, PL_(d_neg)(x0), x1, PL_(d_neg)(x1), y0, PL_(d_neg)(y0),
                  y1, PL_(d_neg)(y1), z0, PL_(d_neg)(z0), z1, PL_(d_neg)(z1)};
    const char *base = (const char *)d;
#define PL_G(c)                                                                              \
    PL_(d_add)(*(const PL_D *)(const void *)(base + pick[c]),                               \
               *(const PL_D *)(const void *)(base + pick[8 + c]))
    PL_D g0 = PL_G(0), g1 = PL_G(1), g2 = PL_G(2), g3 = PL_G(3);
    PL_D g4 = PL_G(4), g5 = PL_G(5), g6 = PL_G(6), g7 = PL_G(7);
#undef PL_G
    return PL_(lerp)(w, PL_(lerp)(v, PL_(lerp)(u, g0, g1), PL_(lerp)(u, g2, g3)),
                     PL_(lerp)(v, PL_(lerp)(u, g4, g5), PL_(lerp)(u, g6, g7)));
}

PL_TARGET static void PL_FN(const double *x, const double *y, const double *z, int n,
                            int octaves, double *out)
{
    /* The last one-cell vector's cell and picks at each octave (the first
     * PL_MEMO_OCTAVES): the next vector is often in the same cell (a pixel's
     * samples, or neighbouring pixels), and its picks, a function of the cell alone,
     * are then taken from here instead of the hash chain's fourteen dependent table
     * lookups. A NaN floor matches nothing. */
    struct {
        double fx, fy, fz;
        uint32_t pick[16];
    } memo[PL_MEMO_OCTAVES];
    for (int o = 0; o < PL_MEMO_OCTAVES; o++)
        memo[o].fx = memo[o].fy = memo[o].fz = (double)NAN;
    /* Each octave's scale and its reciprocal, once per call rather than once per
     * vector and octave (a scalar division each time); octaves beyond the table
     * compute theirs as they come. */
    enum { PL_SCALES = 64 };
    double scales[PL_SCALES], inv_scales[PL_SCALES];
    {
        double sc = 1.0;
        for (int o = 0; o < octaves && o < PL_SCALES; o++, sc *= 2.0) {
            scales[o] = sc;
            inv_scales[o] = 1.0 / sc;
        }
    }
    for (int i = 0; i < n; i += PL_W) {
        double bx[PL_W], by[PL_W], bz[PL_W], bo[PL_W];
        int k = n - i < PL_W ? n - i : PL_W;
        const double *px = x + i, *py = y + i, *pz = z + i;
        if (k < PL_W) {
            /* The last, partial vector: padded with copies of its first point, which
             * lie in its cell (zeros would keep it from noise_cell); the padding
             * lanes' results are dropped. */
            for (int l = 0; l < PL_W; l++) {
                bx[l] = px[l < k ? l : 0];
                by[l] = py[l < k ? l : 0];
                bz[l] = pz[l < k ? l : 0];
            }
            px = bx;
            py = by;
            pz = bz;
        }
        PL_D vx = PL_(d_load)(px), vy = PL_(d_load)(py), vz = PL_(d_load)(pz);
        PL_D sum = PL_(d_set)(0.0);
        double scale = 1.0;
        /* Lanes apart at one octave are apart at every finer one (the cells nest: the
         * scaling by 2 is exact), so the cell test stops at the first miss. Only the
         * speed depends on this: either path gives the same bits. */
        bool cell = true;
        /* Whether lane 0's floors are below 1e9 in magnitude at the finest octave, and
         * so at every octave: x 2^o is exact (or overflows to infinity, which fails
         * here), and |floor(x 2^o)| does not decrease as o grows (floor is monotone and
         * keeps the sign of x 2^o, or gives 0 or -1). Then the per-octave test below
         * is d_one_cell alone (three scalar tests and branches fewer per vector and
         * octave); otherwise, or beyond the table of scales, it is made at each octave
         * as before. */
        bool small = false;
        if (octaves > 0 && octaves <= PL_SCALES) {
            double top = scales[octaves - 1];
            small = fabs(floor(px[0] * top)) < 1e9 && fabs(floor(py[0] * top)) < 1e9 &&
                    fabs(floor(pz[0] * top)) < 1e9;
        }
        for (int o = 0; o < octaves; o++) {
            /* noise / scale as noise * (1 / scale): scale is a power of two (at most
             * 2^63), so 1 / scale is exact, and both are the correctly rounded value
             * of the same real number (also below the normal range): the same bits. */
            PL_D s, r;
            if (o < PL_SCALES) {
                s = PL_(d_set)(scales[o]);
                r = PL_(d_set)(inv_scales[o]);
            } else {
                s = PL_(d_set)(scale);
                r = PL_(d_set)(1.0 / scale);
            }
            PL_D xs = PL_(d_mul)(vx, s), ys = PL_(d_mul)(vy, s), zs = PL_(d_mul)(vz, s);
            PL_D fx = PL_(d_floor)(xs), fy = PL_(d_floor)(ys), fz = PL_(d_floor)(zs);
            double fx0 = PL_(d_lane0)(fx), fy0 = PL_(d_lane0)(fy), fz0 = PL_(d_lane0)(fz);
            /* Not finite or 1e9 and beyond: noise's lanes that answer 0 (and a NaN
             * floor equals nothing, so it never passes d_one_cell). */
            cell = cell && (small || (fabs(fx0) < 1e9 && fabs(fy0) < 1e9 && fabs(fz0) < 1e9)) &&
                   PL_(d_one_cell)(fx, fy, fz);
            PL_D nv;
            if (cell) {
                uint32_t own[16];
                const uint32_t *pick = own;
                if (o < PL_MEMO_OCTAVES) {
                    if (!(memo[o].fx == fx0 && memo[o].fy == fy0 && memo[o].fz == fz0)) {
                        PL_(cell_picks)(fx0, fy0, fz0, memo[o].pick);
                        memo[o].fx = fx0;
                        memo[o].fy = fy0;
                        memo[o].fz = fz0;
                    }
                    pick = memo[o].pick;
                } else {
                    PL_(cell_picks)(fx0, fy0, fz0, own);
                }
                nv = PL_(noise_cell)(xs, ys, zs, fx, fy, fz, pick);
            } else {
                nv = PL_(noise)(xs, ys, zs, fx, fy, fz);
            }
            sum = PL_(d_add)(sum, PL_(d_mul)(nv, r));
            scale *= 2.0;
        }
        if (k < PL_W) {
            PL_(d_store)(bo, sum);
            memcpy(out + i, bo, (size_t)k * sizeof *bo);
        } else {
            PL_(d_store)(out + i, sum);
        }
    }
}
