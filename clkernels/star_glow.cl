// star_glow.cl: Unity Graphics Programming vol.4 ch.4, "StarGlow" (docs/chapters/15-star-glow.md), the book's
// StarGlow.shader passes 1-4 as kernels, after Masaki Kawase's streaks (GDC 2003, DOUBLE-S.T.E.A.L).
// Host: ugpcl/scenes/star_glow.py (Simulation). Images are __global float4 rows in GL order (image.h).
// Kernels, in host call order per frame:
//   0. DemoScene            spheres -> src: the demo's HDR frame, ray-cast lit spheres (not in the book)
//   1. Brightness           src (W x H) -> bright (w x h): pass 1, max(c - threshold, 0) * intensity
//   2. Streak               in -> out (w x h): pass 2, 4 taps along dir * power texels, weights a^(power*j)
//   3. ScreenAccumulate     in, comp -> comp: pass 3, `Blend OneMinusDstColor One` = in + comp - in * comp
//      StreakAllDirections  in layers -> out layers: pass 2 for every direction in one 3-D launch (z = direction)
//      StreakAccumulate     in layers -> comp: the last pass 2 of every direction fused with pass 3 (comp from 0)
//   4. Composite            src, comp -> dst (W x H): pass 4, the five composite modes
//   book order: Brightness; per direction Streak (power 1, 4, 16 ...) then ScreenAccumulate; Composite.
//   variant=fused: Brightness; StreakAllDirections for passes 1 .. n-1; StreakAccumulate; Composite.
// Build defines: none.
// Atomics: none. Races: none; every work-item writes its own texel (ScreenAccumulate reads and writes only its own
// texel of comp, which is how the fixed-function blend is emulated).
// Differences from the book: the book's pass 0 (a plain copy the chapter never uses) has no kernel; comp starts at 0
// each frame (the book blends into an uncleared temporary); tap weights come from the host as exact float32 powers.
#include "image.h"  // image_index, image_uv (texel centre), image_sample_bilinear (GL_LINEAR + CLAMP_TO_EDGE)

#define COMPOSITE_ADDITIVE 0
#define COMPOSITE_SCREEN 1
#define COMPOSITE_COLORED_ADDITIVE 2
#define COMPOSITE_COLORED_SCREEN 3
#define COMPOSITE_DEBUG 4

// The shading of the demo: one directional light (the sample's), Lambert + a strong Blinn-Phong specular whose
// highlights exceed 1, as the sample's HDR camera sees its lit cubes.
__kernel void DemoScene(__global float4* src, int W, int H, const __global float4* spheres,
                        const __global float4* albedo, int count, float4 eye, float tan_half_fov, float4 to_light,
                        float4 light_color, float specular, float shininess) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const float2 ndc = image_uv(x, y, W, H) * 2.0f - 1.0f;
    const float3 ray = normalize((float3)(ndc.x * tan_half_fov * W / H, ndc.y * tan_half_fov, 1.0f));
    float nearest = INFINITY;
    int hit = -1;
    for (int i = 0; i < count; i++) {  // ray-sphere: |eye + t ray - c| = r
        const float3 oc = eye.xyz - spheres[i].xyz;
        const float b = dot(oc, ray), c = dot(oc, oc) - spheres[i].w * spheres[i].w;
        const float disc = b * b - c;
        if (disc < 0.0f) continue;
        const float t = -b - sqrt(disc);
        if (t > 0.0f && t < nearest) {
            nearest = t;
            hit = i;
        }
    }
    float4 colour = (float4)(0.0f, 0.0f, 0.0f, 1.0f);
    if (hit >= 0) {
        const float3 n = normalize(eye.xyz + nearest * ray - spheres[hit].xyz);
        const float3 l = to_light.xyz, half_vector = normalize(l - ray);
        const float diffuse = max(dot(n, l), 0.0f);
        const float highlight = diffuse > 0.0f ? specular * pow(max(dot(n, half_vector), 0.0f), shininess) : 0.0f;
        colour.xyz = albedo[hit].xyz * (0.06f + diffuse * light_color.xyz) + highlight * light_color.xyz;
    }
    src[image_index(x, y, W)] = colour;
}

// Pass 1: one bilinear tap of the source at the centre of the small target's texel.
__kernel void Brightness(const __global float4* src, int W, int H, __global float4* bright, int w, int h,
                         float threshold, float intensity) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h) return;
    const float4 colour = image_sample_bilinear(src, W, H, image_uv(x, y, w, h));
    bright[image_index(x, y, w)] = fmax(colour - threshold, 0.0f) * intensity;
}

// The 4 taps of pass 2 at texel (x, y): uv walks `step` (dir * power texels) and every tap is saturated after its
// weight, as the book's `saturate(tex2D(_MainTex, uv) * pow(ATTENUATION, power * j))`.
inline float4 streak_taps(const __global float4* in, int w, int h, int x, int y, float2 step, float4 weights) {
    float2 uv = image_uv(x, y, w, h);
    float4 sum = 0.0f;
    const float weight[4] = {weights.x, weights.y, weights.z, weights.w};
    for (int j = 0; j < 4; j++) {
        sum += clamp(image_sample_bilinear(in, w, h, uv) * weight[j], 0.0f, 1.0f);
        uv += step;
    }
    return sum;
}

inline float2 streak_step(float2 dir, float power, int w, int h) { return dir * power / (float2)(w, h); }

// Pass 2: weights = (1, a^power, a^(2 power), a^(3 power)).
__kernel void Streak(const __global float4* in, __global float4* out, int w, int h, float2 dir, float power,
                     float4 weights) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h) return;
    out[image_index(x, y, w)] = streak_taps(in, w, h, x, y, streak_step(dir, power, w, h), weights);
}

// Pass 3 with `Blend OneMinusDstColor One`: src * (1 - dst) + dst, unclamped (float targets).
__kernel void ScreenAccumulate(const __global float4* in, __global float4* comp, int w, int h) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h) return;
    const int i = image_index(x, y, w);
    const float4 s = in[i], d = comp[i];
    comp[i] = s + d - s * d;
}

// Pass 2 for every direction: layer z of `out` from layer z of `in` (in_stride = 0: every direction reads the one
// brightness image, the first pass).
__kernel void StreakAllDirections(const __global float4* in, __global float4* out, int w, int h, int in_stride,
                                  const __global float2* dirs, float power, float4 weights) {
    const int x = get_global_id(0), y = get_global_id(1), d = get_global_id(2);
    if (x >= w || y >= h) return;
    const __global float4* layer = in + (size_t)d * in_stride;
    out[(size_t)d * w * h + image_index(x, y, w)] =
        streak_taps(layer, w, h, x, y, streak_step(dirs[d], power, w, h), weights);
}

// The last pass 2 of every direction, screen-blended in direction order into a comp that starts at 0: the book's
// per-direction Blit + blend without storing the final streaks.
__kernel void StreakAccumulate(const __global float4* in, __global float4* comp, int w, int h, int in_stride,
                               const __global float2* dirs, int count, float power, float4 weights) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h) return;
    float4 acc = 0.0f;
    for (int d = 0; d < count; d++) {
        const float4 s = streak_taps(in + (size_t)d * in_stride, w, h, x, y, streak_step(dirs[d], power, w, h), weights);
        acc = s + acc - s * acc;
    }
    comp[image_index(x, y, w)] = acc;
}

// Pass 4: the source texel and a bilinear tap of comp at the full-resolution uv.
__kernel void Composite(const __global float4* src, int W, int H, const __global float4* comp, int w, int h,
                        __global float4* dst, int mode, float4 color) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const float4 main_colour = src[image_index(x, y, W)];
    float4 glow = image_sample_bilinear(comp, w, h, image_uv(x, y, W, H));
    if (mode == COMPOSITE_COLORED_ADDITIVE || mode == COMPOSITE_COLORED_SCREEN)
        glow.xyz = (glow.x + glow.y + glow.z) * 0.3333f * color.xyz;
    float4 out;
    if (mode == COMPOSITE_SCREEN || mode == COMPOSITE_COLORED_SCREEN)
        out = clamp(main_colour + glow - clamp(main_colour * glow, 0.0f, 1.0f), 0.0f, 1.0f);
    else if (mode == COMPOSITE_ADDITIVE || mode == COMPOSITE_COLORED_ADDITIVE)
        out = clamp(main_colour + glow, 0.0f, 1.0f);
    else
        out = glow;
    dst[image_index(x, y, W)] = out;
}
