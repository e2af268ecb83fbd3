// kleinian.h: the per-point and per-pixel core of vol.4 ch.2, "Limit sets of Kleinian groups"
// (docs/chapters/13-kleinian.md): Jos Leys' escape-time test of the book's KleinianGroup.shader, written ONCE in the
// subset that OpenCL C and GLSL 4.30 share. clkernels/kleinian.cl includes it as an OpenCL header; the viewer's
// viewer/shaders/kleinian.frag and kleinian_overlay.frag include the very same file (viewer/views/kleinian.py serves
// it to moderngl's #include), so the kernel and the shader run the same text, not two translations of it.
//
// The few words the two languages spell differently are the macros of the first section: `real`/`real2` (float or,
// with KLEINIAN_DOUBLE=1, double), REAL(x) and REAL2(x, y) for conversions and constructors, INT2, UINT, ABS (OpenCL's
// abs() is integer-only). Everything else (floor, exp, sign, dot, length, sin, cos, uint arithmetic) means the same
// in both. No pointers (GLSL has none) and no `out` parameters: functions return values, two ints as an int2.
//
//   jos_kleinian(z, t, iteration)   +n: z is in the limit set's disk orbit (hit after n steps); -n: miss after n
//   kleinian_line3(x, u, v)         y of Line3, the empirical separation line of the original shader
//   kleinian_pixel_point(...)       the book's screen -> world mapping of passes 0/1 ((uv + offset) * scale) and 2
//                                   (uv * scale + offset)
//   kleinian_sample_point(...)      sample i of a pixel: one-sided jitter rand2 * jitter / H, then (pass 2) the extra
//                                   circle inversion
//   kleinian_pixel(...)             int2(hits among the samples, iterations of sample 0)
#ifndef UGPCL_KLEINIAN_H
#define UGPCL_KLEINIAN_H

// {{{ the two languages

#ifdef __OPENCL_VERSION__
#if KLEINIAN_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
typedef double2 real2;
#else
typedef float real;
typedef float2 real2;
#endif
#define KL_FN inline
#define REAL(x) ((real)(x))
#define REAL2(x, y) ((real2)((x), (y)))
#define INT2(a, b) ((int2)((a), (b)))
#define UINT(x) ((uint)(x))
#define ABS(x) fabs(x)
#else  // GLSL 4.30
#if KLEINIAN_DOUBLE
#define real double
#define real2 dvec2
#else
#define real float
#define real2 vec2
#endif
#define int2 ivec2
#define KL_FN
#define REAL(x) real(x)
#define REAL2(x, y) real2(x, y)
#define INT2(a, b) ivec2(a, b)
#define UINT(x) uint(x)
#define ABS(x) abs(x)
#endif

// }}}

// {{{ Jos Leys' algorithm (book 2.5.2, KleinianGroup.shader josKleinian)

// wrap(): fold x into [left_side, left_side + width) (book 2.6).
KL_FN real kleinian_wrap(real x, real width, real left_side) {
    x -= left_side;
    return (x - width * floor(x / width)) + left_side;
}

// Line3: the y that splits the central parallelogram into two halves point-symmetric about (-v/2, u/2). The book
// (2.6) says it is "found by eye from the figure's symmetry"; for v = 0 it is the straight line y = u/2 (sign(0) = 0
// in both languages). The original evaluates it in this order.
KL_FN real kleinian_line3(real x, real u, real v) {
    const real d = x + v * REAL(0.5);
    return u * REAL(0.5) + sign(v) * (REAL(2.0) * u - REAL(1.95)) / REAL(4.0) * sign(d) *
                               (REAL(1.0) - exp(-(REAL(7.2) - (REAL(1.95) - u) * REAL(15.0)) * ABS(d)));
}

// TransA: a(z) = (tz - i) / (-iz) = conj(z) / |z|^2 + (-v + iu): invert in the unit circle, negate y, translate.
KL_FN real2 kleinian_trans_a(real2 z, real2 t) { return REAL2(z.x, -z.y) / dot(z, z) + REAL2(-t.y, t.x); }

// The escape-time test of one point z for t = (u, v): +n when the n-th application of a lands below y = 0 (z was
// in an image of the largest disk: in the limit set's picture), -n when the orbit came back to where it was two
// steps before (a 2-cycle across Line3: outside) or the iteration budget ran out (n = iteration).
KL_FN int jos_kleinian(real2 z, real2 t, int iteration) {
    const real u = t.x, v = t.y;
    real2 lz = z + REAL2(REAL(1.0), REAL(1.0));  // any two points distinct from z and from each other
    real2 llz = z - REAL2(REAL(1.0), REAL(1.0));
    for (int i = 0; i < iteration; i++) {
        // fold into the parallelogram between Line1 and Line2: shear it to a rectangle, wrap, shear back
        const real offset_x = ABS(v) / u * z.y;
        z.x += offset_x;
        z.x = kleinian_wrap(z.x, REAL(2.0), REAL(-1.0));
        z.x -= offset_x;
        // above Line3: use the point symmetry about (-v/2, u/2)
        if (z.y >= kleinian_line3(z.x, u, v)) z = REAL2(-v, u) - z;
        z = kleinian_trans_a(z, t);
        if (z.y < REAL(0.0)) return i + 1;                      // hit
        if (length(z - llz) < REAL(1e-6)) return -(i + 1);  // 2-cycle: miss
        llz = lz;
        lz = z;
    }
    return -iteration;
}

// }}}

// {{{ pixels (the three passes of KleinianGroup.shader)

// PCG hash (M. Jarzynski, M. Olano, "Hash Functions for GPU Rendering", JCGT 2020): the same bits everywhere.
KL_FN uint kleinian_pcg(uint v) {
    const uint state = v * 747796405u + 2891336453u;
    const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// hash = 0 (ugpcl's default): sample i of pixel `pixel` in [0, 1)^2 from 24-bit integers (exact in float).
KL_FN real2 kleinian_rand2_portable(uint pixel, int i) {
    const uint a = kleinian_pcg(pixel ^ kleinian_pcg(UINT(i)));
    const uint b = kleinian_pcg(a);
    return REAL2(REAL(a >> 8u), REAL(b >> 8u)) * REAL(1.0 / 16777216.0);
}

// hash = 1: the original rand2n(co, i); sin of large arguments differs between devices (compare statistically).
KL_FN real2 kleinian_rand2_sin(real2 co, int i) {
    const real2 s = co * REAL(i + 1) + REAL2(REAL(-1.0), REAL(1.0));
    const real a = sin(dot(s, REAL2(REAL(12.9898), REAL(78.233)))) * REAL(43758.5453);
    const real b = cos(dot(s, REAL2(REAL(4.898), REAL(7.23)))) * REAL(23421.631);
    return REAL2(a - floor(a), b - floor(b));
}

// circleInverse(pos, center, radius): the original multiplies by `radius` / |p|^2, so circle_w acts as r^2.
KL_FN real2 kleinian_circle_inverse(real2 pos, real2 center, real circle_w) {
    real2 p = pos - center;
    p = (p * circle_w) / dot(p, p);
    return p + center;
}

// World point of the centre of pixel (x, y), y = 0 the bottom row: uv = ((x + 0.5) / W, (y + 0.5) / H), x scaled by
// the aspect W / H; passes 0 and 1 apply (pos + offset) * scale, pass 2 pos * scale + offset (book 2.6 and 2.7: the
// opposite order, kept).
KL_FN real2 kleinian_pixel_point(int x, int y, int width, int height, real scale, real2 offset, int mode) {
    real2 pos = REAL2((REAL(x) + REAL(0.5)) / REAL(width), (REAL(y) + REAL(0.5)) / REAL(height));
    pos.x *= REAL(width) / REAL(height);
    if (mode == 2) return pos * scale + offset;
    return (pos + offset) * scale;
}

// Sample i of the pixel whose world point is p: pass 0 takes p itself; passes 1 and 2 add the book's one-sided
// jitter rand2 * (1 / H) * jitter (world units: it does not follow scale); pass 2 then inverts in the circle.
KL_FN real2 kleinian_sample_point(real2 p, uint pixel, int i, int height, int mode, real jitter, int hash,
                                  real2 circle_center, real circle_w) {
    real2 q = p;
    if (mode != 0) {
        const real2 r = hash == 0 ? kleinian_rand2_portable(pixel, i) : kleinian_rand2_sin(p, i);
        q += r * (REAL(1.0) / REAL(height)) * jitter;
    }
    if (mode == 2) q = kleinian_circle_inverse(q, circle_center, circle_w);
    return q;
}

// int2(hits among `samples` samples, iterations of sample 0) of pixel (x, y).
KL_FN int2 kleinian_pixel(int x, int y, int width, int height, real2 t, real scale, real2 offset, real2 circle_center,
                          real circle_w, int iteration, int mode, int samples, real jitter, int hash) {
    const real2 p = kleinian_pixel_point(x, y, width, height, scale, offset, mode);
    const uint pixel = UINT(x) + UINT(y) * UINT(width);
    int hits = 0, first = 0;
    for (int i = 0; i < samples; i++) {
        const real2 q = kleinian_sample_point(p, pixel, i, height, mode, jitter, hash, circle_center, circle_w);
        const int n = jos_kleinian(q, t, iteration);
        hits += n > 0 ? 1 : 0;
        if (i == 0) first = n > 0 ? n : -n;
    }
    return INT2(hits, first);
}

// }}}

#endif
