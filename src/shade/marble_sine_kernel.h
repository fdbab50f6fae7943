/* Marble's sine, td[i] = (sin(a[i]) + 1) / 2 in double within 2.5e-16 + 1.2e-16 of the
 * true value for |a[i]| <= MARBLE_SIN_MAX (marble.c, marble_sine_weights, holds the
 * argument and the check of each lane), written once and included by marble.c once per
 * width: the includer defines MS_NAME and MS_W (doubles per vector: 2, 4 or 8, the
 * width of the instruction set the inclusion is compiled for). n is padded to a
 * multiple of MS_W by the caller (the lanes past n are computed and not used).
 *
 * k = a 2/pi rounded (the 1.5 2^52 trick: its low bits are k mod 4, the quadrant),
 * r = a - k pi/2 by Cody and Waite (k pio2_hi exact for |k| < 2^20, pio2_hi having 33
 * bits; a - k pio2_hi exact by Sterbenz; pi/2 - pio2_hi - pio2_lo < 2e-27: r within 6e-17
 * of the reduced argument), then the Taylor series of sin and cos on |r| <= pi/4 to r^17
 * and r^18 (truncation < 1e-19) by Estrin's scheme in r^2 (rounding < 2.5e-16, the
 * leading terms exact), the quadrant's one chosen and signed. */

#define MS_CAT2(a, b) a##b
#define MS_CAT(a, b) MS_CAT2(a, b)
#define MS_V MS_CAT(MS_NAME, _v)
#define MS_I MS_CAT(MS_NAME, _i)

typedef double MS_V __attribute__((vector_size(8 * MS_W)));
typedef int64_t MS_I __attribute__((vector_size(8 * MS_W)));

static void MS_NAME(const double *a, int n, double *td)
{
    const double pio2_hi = 1.57079632673412561417e+00, pio2_lo = 6.07710050650619224932e-11;
    const double two_over_pi = 6.36619772367581382433e-01, round = 0x1.8p52;
    for (int i = 0; i < n; i += MS_W) {
        MS_V x;
        memcpy(&x, a + i, sizeof x);
        MS_V kk = x * two_over_pi + round; /* 1.5 2^52 + k */
        MS_V k = kk - round;
        MS_V r = (x - k * pio2_hi) - k * pio2_lo;
        MS_V r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
        /* 1/n! for n = 3, 5, ..., 17 (sin) and 2, 4, ..., 18 (cos), with their signs */
        MS_V s01 = -1.0 / 6.0 + r2 * (1.0 / 120.0), s23 = -1.0 / 5040.0 + r2 * (1.0 / 362880.0);
        MS_V s45 = -1.0 / 39916800.0 + r2 * (1.0 / 6227020800.0);
        MS_V s67 = -1.0 / 1307674368000.0 + r2 * (1.0 / 355687428096000.0);
        MS_V s = r + r * (r2 * ((s01 + r4 * s23) + r8 * (s45 + r4 * s67)));
        MS_V c01 = 0.5 - r2 * (1.0 / 24.0), c23 = 1.0 / 720.0 - r2 * (1.0 / 40320.0);
        MS_V c45 = 1.0 / 3628800.0 - r2 * (1.0 / 479001600.0);
        MS_V c67 = 1.0 / 87178291200.0 - r2 * (1.0 / 20922789888000.0);
        MS_V c89 = c67 + r4 * (1.0 / 6402373705728000.0);
        MS_V c = 1.0 - r2 * ((c01 + r4 * c23) + r8 * (c45 + r4 * c89));
        MS_I q;
        memcpy(&q, &kk, sizeof q);
        MS_I odd = (q & 1) != 0; /* quadrants 1 and 3: cos r; 2 and 3: negated */
        MS_I v = ((MS_I)c & odd) | ((MS_I)s & ~odd);
        v ^= (q & 2) << 62;
        MS_V t = ((MS_V)v + 1.0) * 0.5;
        memcpy(td + i, &t, sizeof t);
    }
}

#undef MS_CAT2
#undef MS_CAT
#undef MS_V
#undef MS_I
#undef MS_NAME
#undef MS_W
