// random.h: random numbers for the kernels, two kinds.
//
// 1. The books' shader hash and the helpers built on it, as the samples' Random.cginc defines them (used by
//    vol.3 ch.4 cellular growth, docs/chapters/11-cellular-growth.md, and vol.4 ch.1 space colonization,
//    docs/chapters/12-space-colonization.md):
//      nrand(uv)                   frac(sin(dot(uv, (12.9898, 78.233))) * 43758.5453), in [0, 1)
//      random_point_on_circle(uv)  (cos, sin) of the angle nrand(uv) * 2 pi
//      random_point_on_sphere(uv)  z = nrand(uv) * 2 - 1, angle nrand(uv + 0.333) * 2 pi: uniform on the unit sphere
//    They are hashes of a float2, not a generator: their values for large arguments depend on the device's sin
//    (PoCL and NVIDIA differ), so results driven by them are compared statistically, never bit for bit.
//
// 2. Philox-4x32-10, a counter-based generator (J. K. Salmon, M. A. Moraes, R. O. Dror, D. E. Shaw, "Parallel
//    random numbers: as easy as 1, 2, 3", SC'11; the Random123 library): a bijection of a 128-bit counter under a
//    64-bit key. A work-item draws the numbers of (item, step, ...) by putting them in the counter and the seed in
//    the key: no state to store, the same numbers on every device, and a bit-exact numpy twin in ugpcl/random.py
//    (philox4x32, uniform01), checked against Random123's known-answer vectors in tests/test_random.py.
//      philox4x32_10(counter, key)  four independent uint32
//      philox_uniform4(counter, key) four floats in [0, 1): uniform01 of each of the above
#ifndef UGPCL_RANDOM_H
#define UGPCL_RANDOM_H

// {{{ the books' hash (Random.cginc)

inline float nrand(float2 uv) {
    const float x = sin(dot(uv, (float2)(12.9898f, 78.233f))) * 43758.5453f;
    return x - floor(x);  // HLSL frac (OpenCL's fract needs a pointer argument)
}

inline float2 random_point_on_circle(float2 uv) {
    const float theta = nrand(uv) * 2.0f * M_PI_F;
    return (float2)(cos(theta), sin(theta));
}

// Uniform on the unit sphere: z uniform in [-1, 1), the angle around z uniform (Archimedes' hat-box theorem).
inline float3 random_point_on_sphere(float2 uv) {
    const float u = nrand(uv) * 2.0f - 1.0f;
    const float theta = nrand(uv + (float2)(0.333f)) * 2.0f * M_PI_F;
    const float u2 = sqrt(1.0f - u * u);
    return (float3)(u2 * cos(theta), u2 * sin(theta), u);
}

// }}}

// {{{ Philox-4x32-10 (Salmon et al. 2011); numpy twin: ugpcl.random

#define PHILOX_M0 0xD2511F53u  // round multipliers (Random123: PHILOX_M4x32_0, PHILOX_M4x32_1)
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u  // key schedule (Weyl) increments: the golden ratio and sqrt(3) - 1, times 2^32
#define PHILOX_W1 0xBB67AE85u

// One round: two 32x32 -> 64-bit products, their high halves mixed with the other two words and the key.
inline uint4 philox4x32_round(uint4 c, uint2 k) {
    const uint hi0 = mul_hi(PHILOX_M0, c.x), lo0 = PHILOX_M0 * c.x;
    const uint hi1 = mul_hi(PHILOX_M1, c.z), lo1 = PHILOX_M1 * c.z;
    return (uint4)(hi1 ^ c.y ^ k.x, lo1, hi0 ^ c.w ^ k.y, lo0);
}

// Ten rounds, the key bumped between rounds (Random123's philox4x32_R with R = 10).
inline uint4 philox4x32_10(uint4 counter, uint2 key) {
    for (int r = 0; r < 10; r++) {
        if (r > 0) key += (uint2)(PHILOX_W0, PHILOX_W1);  // wraps mod 2^32
        counter = philox4x32_round(counter, key);
    }
    return counter;
}

// A float in [0, 1) from the top 24 bits: (x >> 8) * 2^-24, exact in float32 (numpy: ugpcl.random.uniform01).
inline float uniform01(uint x) { return (float)(x >> 8) * 0x1.0p-24f; }

inline float4 philox_uniform4(uint4 counter, uint2 key) {
    const uint4 x = philox4x32_10(counter, key);
    return (float4)(uniform01(x.x), uniform01(x.y), uniform01(x.z), uniform01(x.w));
}

// }}}

#endif
