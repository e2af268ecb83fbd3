// projection_spray.cl: Unity Graphics Programming vol.1 ch.10, "Introduction to Projection Spray"
// (docs/chapters/10-projection-spray.md). The chapter describes no algorithm; these kernels follow the author's
// linked sample (sugi-cho/ProjectionSpray: DrawingManager, ProjectionSpray.cs, the "Hidden/Projectionspray" and
// "Hidden/EdgeThicken" shaders) as the chapter page retells it.
// Host: ugpcl/scenes/projection_spray.py (Simulation).
// Kernels, in host call order per frame:
//   1. SprayDepthClear  depth (D x D uint, float bits) := range: the spray's distance map, cleared to its far plane
//   2. SprayDepthBoxes  world triangles -> boxes: each triangle's bounding box of depth pixels (int4 x0, y0, x1, y1;
//                       empty when it misses the map), read back for the host to list (triangle, block) pairs
//   3. SprayDepth       world triangles, boxes, pairs -> depth: one work-item per listed (triangle, block) pair casts
//                       the ray of each pixel of the DEPTH_BLOCK x DEPTH_BLOCK block inside the triangle's box
//                       exactly against the triangle and keeps the nearest distance with atomic_min (the sample
//                       renders a distance shader into an RFloat target)
//      SprayDepth_serial  the same map, one work-item per triangle looping over its whole box: the plain form, and
//                       the tests' reference (a big triangle is ~10^6 pixels in series: not used by the scene)
//   then, for each drawable whose tiles the spray can reach, over those tiles only:
//   4. SprayDraw / SprayGuide  pos_tex, nrm_tex, shape, depth -> paint (in place; pass 0 of the sample, while
//                       painting): the texel lerps toward the spray colour by shape * occlusion * cos(incidence) *
//                       distance falloff * dt * emission; or -> guide (cleared by the host; pass 1, while not
//                       painting): the same footprint as a preview
//   5. EdgeThicken      paint -> canvas (guide -> guide canvas): texels outside every island take a bilinear
//                       sample from inside the nearest one, edge_texels away ("Hidden/EdgeThicken")
//   then, for the viewer, of each texture that changed since it last looked:
//   6. CanvasToRGBA8    canvas or guide canvas -> rgba8 (uchar4 per texel): 8-bit colour, a quarter of the bytes
// Build defines: none. Texture tiles are TILE x TILE texels (host: TILE); a launch covers the tiles listed in
// `tiles`, one work-item per texel of each. Depth blocks are DEPTH_BLOCK x DEPTH_BLOCK pixels (host: DEPTH_BLOCK).
// Atomics: atomic_min on the depth map's uint bits (IEEE order equals uint order for floats >= 0).
// Races: none. Every texel kernel reads and writes only its own texel of the texture it writes; EdgeThicken reads
// `src` and writes another buffer.
// Differences from the sample: the spray's texel kernels write in place instead of blitting a ping-pong pair (each
// reads only its own texel, so the pair buys nothing and would force copying the tiles it skips); EdgeThicken
// writes a separate canvas instead of folding the dilation back into the paint (the result is then a function of
// the paint alone, so recomputing only the tiles near new paint gives the same texture as a full pass); the
// falloff 1 - dist/range is clamped at 0 (beyond range the sample's factor turns negative); a zero dilation
// direction keeps the texel (the sample normalises a zero vector).
#include "image.h"  // image_index, image_load_clamped, image_sample_bilinear (GL row order, clamped bilinear)

#define TILE 16
#define DEPTH_BLOCK 16

// Offsets into the per-drawable uniform block (`u`, flat float32, host: UNIFORM_* in the scene module).
#define U_O2W 0         // object -> world, row-major 4x4
#define U_PROJ 16       // world -> spray uv: Offset * P * V, row-major 4x4
#define U_W2D 32        // world -> spray local (+z forward), row-major 4x4
#define U_COLOR 48      // spray colour rgba
#define U_EMISSION 52   // paint alpha per second
#define U_RANGE 53      // far plane and falloff distance
#define U_DT 54         // frame time
#define U_SHARPNESS 55  // occlusion compare band = 1 / sharpness
#define U_BIAS 56       // occlusion bias

// Row-major 4x4 times (v, w).
inline float4 transform(__global const float* m, float3 v, float w) {
    const float4 p = (float4)(v, w);
    return (float4)(dot(vload4(0, m), p), dot(vload4(1, m), p), dot(vload4(2, m), p), dot(vload4(3, m), p));
}

// One-channel clamped bilinear sample (image.h's rule on a float image): the depth map.
inline float depth_sample_bilinear(__global const float* img, int w, int h, float2 uv) {
    const float2 size = (float2)((float)w, (float)h);
    const float2 p = clamp(uv * size - 0.5f, (float2)(-1.0f), size);
    const float2 base = floor(p);
    const float2 t = p - base;
    const int x0 = clamp((int)base.x, 0, w - 1), x1 = clamp((int)base.x + 1, 0, w - 1);
    const int y0 = clamp((int)base.y, 0, h - 1), y1 = clamp((int)base.y + 1, 0, h - 1);
    const float bottom = mix(img[image_index(x0, y0, w)], img[image_index(x1, y0, w)], t.x);
    const float top = mix(img[image_index(x0, y1, w)], img[image_index(x1, y1, w)], t.x);
    return mix(bottom, top, t.y);
}

// Texel (x, y) of the `item`-th texel of a launch over the listed tiles; false past the texture's edge.
inline bool tile_texel(__global const int* tiles, int tiles_x, int w, int h, int* x, int* y) {
    const int item = get_global_id(0);
    const int tile = tiles[item / (TILE * TILE)];
    const int within = item % (TILE * TILE);
    *x = (tile % tiles_x) * TILE + within % TILE;
    *y = (tile / tiles_x) * TILE + within / TILE;
    return *x < w && *y < h;
}

// The sample's paint alpha at a surface texel (before colour.a * dt * emission): 0 outside the frustum, the shape,
// range or the light, and where the depth map sees something nearer.
// `tint` receives the shape texture's rgb at the texel's spray uv.
inline float spray_alpha(float4 p, float4 n, __global const float4* shape, int shape_res, __global const float* depth,
                         int depth_res, __global const float* u, float3* tint) {
    *tint = (float3)(0.0f);
    if (p.w < 0.5f) return 0.0f;  // not on the surface (the sample moves such texels 10000 units away)
    const float3 wp = transform(u + U_O2W, p.xyz, 1.0f).xyz;
    const float3 wn = normalize(transform(u + U_O2W, n.xyz, 0.0f).xyz);  // uniform scale: the 3x3 of O2W
    const float4 c = transform(u + U_PROJ, wp, 1.0f);
    if (!(c.z > 0.0f && c.w > 0.0f)) return 0.0f;  // behind the near plane: test before dividing
    const float2 s = c.xy / c.w;
    if (!(fabs(s.x - 0.5f) < 0.5f && fabs(s.y - 0.5f) < 0.5f)) return 0.0f;
    const float3 lp = transform(u + U_W2D, wp, 1.0f).xyz;
    const float3 ln = transform(u + U_W2D, wn, 0.0f).xyz;
    const float dist = length(lp);
    const float atten = fmax(0.0f, dot(ln, -lp / dist));
    const float occ = depth_sample_bilinear(depth, depth_res, depth_res, s);
    const float lit = 1.0f - clamp((dist - occ - u[U_BIAS]) * u[U_SHARPNESS], 0.0f, 1.0f);
    const float falloff = fmax(0.0f, 1.0f - dist / u[U_RANGE]);
    const float4 spray = image_sample_bilinear(shape, shape_res, shape_res, s);
    *tint = spray.xyz;
    return spray.w * lit * atten * falloff;
}

#define SPRAY_ARGS                                                                                          \
    __global const int *tiles, int tiles_x, int tex_w, int tex_h, __global const float4 *pos_tex,          \
        __global const float4 *nrm_tex, __global const float4 *shape, int shape_res, __global const float *depth, \
        int depth_res, __global const float *u

__kernel void SprayDepthClear(__global uint* depth, int count, float range) {
    const int i = get_global_id(0);
    if (i < count) depth[i] = as_uint(range);
}

// The depth kernels' last arguments: the map's resolution D, the spray's origin and unit axes, tan of half its
// field of view, its range (host: Simulation.depth_frame).
#define DEPTH_ARGS                                                                                                 \
    int depth_res, float4 origin, float4 right, float4 up, float4 forward, float tan_half_fov, float range

// Bounding box (x0, y0, x1, y1, inclusive) of the depth pixels whose centre (i + 0.5) / D lies in the box of the
// triangle's projected corners, one pixel of margin for rounding; a corner at or behind the spray's plane: the whole
// map. False when the triangle's box misses the map.
inline bool depth_box(float3 a, float3 b, float3 c, int depth_res, float3 origin, float3 right, float3 up,
                      float3 forward, float tan_half_fov, int4* box) {
    *box = (int4)(0, 0, depth_res - 1, depth_res - 1);
    const float3 corners[3] = {a, b, c};
    float2 lo = (float2)(INFINITY), hi = (float2)(-INFINITY);
    for (int m = 0; m < 3; ++m) {
        const float3 d = corners[m] - origin;
        const float z = dot(d, forward);
        if (!(z > 1e-6f)) return true;
        const float2 s = (float2)(dot(d, right), dot(d, up)) / (z * tan_half_fov) * 0.5f + 0.5f;
        lo = fmin(lo, s);
        hi = fmax(hi, s);
    }
    if (hi.x < 0.0f || hi.y < 0.0f || lo.x > 1.0f || lo.y > 1.0f) return false;
    box->x = max(0, (int)floor(lo.x * depth_res - 0.5f) - 1);
    box->y = max(0, (int)floor(lo.y * depth_res - 0.5f) - 1);
    box->z = min(depth_res - 1, (int)ceil(hi.x * depth_res - 0.5f) + 1);
    box->w = min(depth_res - 1, (int)ceil(hi.y * depth_res - 0.5f) + 1);
    return true;
}

// Spray ray through depth pixel (i, j): origin + t (forward + sx right + sy up), sx, sy = (2 uv - 1) tan(fov / 2),
// cast against the triangle (a, a + e1, a + e2), both faces (Moller-Trumbore); a hit nearer than range lowers the
// pixel's distance.
inline void depth_pixel(int i, int j, float3 a, float3 e1, float3 e2, volatile __global uint* depth, int depth_res,
                        float3 origin, float3 right, float3 up, float3 forward, float tan_half_fov, float range) {
    const float sx = (2.0f * (i + 0.5f) / depth_res - 1.0f) * tan_half_fov;
    const float sy = (2.0f * (j + 0.5f) / depth_res - 1.0f) * tan_half_fov;
    const float3 dir = forward + sx * right + sy * up;
    const float3 to_origin = origin - a;
    const float3 pv = cross(dir, e2);
    const float det = dot(e1, pv);
    if (fabs(det) < 1e-12f) return;
    const float inv = 1.0f / det;
    const float bu = dot(to_origin, pv) * inv;
    if (bu < 0.0f || bu > 1.0f) return;
    const float3 qv = cross(to_origin, e1);
    const float bv = dot(dir, qv) * inv;
    if (bv < 0.0f || bu + bv > 1.0f) return;
    const float t = dot(e2, qv) * inv;
    if (!(t > 0.0f)) return;
    const float dist = t * length(dir);
    if (dist < range) atomic_min(&depth[image_index(i, j, depth_res)], as_uint(dist));
}

// One work-item per triangle: its box, (0, 0, -1, -1) when it misses the map (no block of it is listed).
__kernel void SprayDepthBoxes(__global const float4* triangles, int count, __global int4* boxes, DEPTH_ARGS) {
    const int k = get_global_id(0);
    if (k >= count) return;
    int4 box;
    const bool on_map = depth_box(triangles[3 * k].xyz, triangles[3 * k + 1].xyz, triangles[3 * k + 2].xyz, depth_res,
                                  origin.xyz, right.xyz, up.xyz, forward.xyz, tan_half_fov, &box);
    boxes[k] = on_map ? box : (int4)(0, 0, -1, -1);
}

// One work-item per (triangle, block) pair, pairs[p] = (triangle, row * blocks_x + column), over the pixels of the
// DEPTH_BLOCK x DEPTH_BLOCK block at (column, row) * DEPTH_BLOCK that lie inside the triangle's box. The host lists
// every block a box meets, so exactly SprayDepth_serial's pixels are cast, at most DEPTH_BLOCK^2 per work-item
// whatever the triangle's size (SprayDepth_serial casts a triangle that covers the map in D^2 steps of one
// work-item). A loop over the block rather than a work-item per pixel: the figure's small triangles would leave most
// of a block's work-items idle, which costs a CPU device more than the loop costs a GPU.
__kernel void SprayDepth(__global const float4* triangles, __global const int4* boxes, __global const int2* pairs,
                         int pair_count, int blocks_x, volatile __global uint* depth, DEPTH_ARGS) {
    const int p = get_global_id(0);
    if (p >= pair_count) return;
    const int2 pair = pairs[p];
    const int4 box = boxes[pair.x];
    const int x0 = (pair.y % blocks_x) * DEPTH_BLOCK, y0 = (pair.y / blocks_x) * DEPTH_BLOCK;
    const float3 a = triangles[3 * pair.x].xyz, b = triangles[3 * pair.x + 1].xyz, c = triangles[3 * pair.x + 2].xyz;
    for (int j = max(y0, box.y); j <= min(y0 + DEPTH_BLOCK - 1, box.w); ++j) {
        for (int i = max(x0, box.x); i <= min(x0 + DEPTH_BLOCK - 1, box.z); ++i) {
            depth_pixel(i, j, a, b - a, c - a, depth, depth_res, origin.xyz, right.xyz, up.xyz, forward.xyz,
                        tan_half_fov, range);
        }
    }
}

__kernel void SprayDepth_serial(__global const float4* triangles, int count, volatile __global uint* depth,
                                DEPTH_ARGS) {
    const int k = get_global_id(0);
    if (k >= count) return;
    const float3 a = triangles[3 * k].xyz, b = triangles[3 * k + 1].xyz, c = triangles[3 * k + 2].xyz;
    int4 box;
    if (!depth_box(a, b, c, depth_res, origin.xyz, right.xyz, up.xyz, forward.xyz, tan_half_fov, &box)) return;
    for (int j = box.y; j <= box.w; ++j) {
        for (int i = box.x; i <= box.z; ++i) {
            depth_pixel(i, j, a, b - a, c - a, depth, depth_res, origin.xyz, right.xyz, up.xyz, forward.xyz,
                        tan_half_fov, range);
        }
    }
}

__kernel void SprayDraw(SPRAY_ARGS, __global float4* paint) {
    int x, y;
    if (!tile_texel(tiles, tiles_x, tex_w, tex_h, &x, &y)) return;
    const int i = image_index(x, y, tex_w);
    float3 tint;
    const float a = spray_alpha(pos_tex[i], nrm_tex[i], shape, shape_res, depth, depth_res, u, &tint);
    if (a <= 0.0f) return;  // unchanged: rgb = mix(rgb, col, 0)
    const float4 color = vload4(0, u + U_COLOR);
    const float3 col = tint * color.xyz;
    const float weight = a * color.w * u[U_DT] * u[U_EMISSION];
    paint[i] = (float4)(mix(paint[i].xyz, col, weight), 1.0f);
}

__kernel void SprayGuide(SPRAY_ARGS, __global float4* guide) {
    int x, y;
    if (!tile_texel(tiles, tiles_x, tex_w, tex_h, &x, &y)) return;
    const int i = image_index(x, y, tex_w);
    float3 tint;
    const float a = spray_alpha(pos_tex[i], nrm_tex[i], shape, shape_res, depth, depth_res, u, &tint);
    const float4 color = vload4(0, u + U_COLOR);
    const float3 col = tint * color.xyz;
    const float alpha = a * color.w;
    const float4 mixed = mix(guide[i], (float4)(col, alpha), alpha);
    guide[i] = (float4)(mixed.xyz, alpha);
}

__kernel void EdgeThicken(__global const int* tiles, int tiles_x, int tex_w, int tex_h, __global const float4* pos_tex,
                          int edge_texels, __global const float4* src, __global float4* dst) {
    int x, y;
    if (!tile_texel(tiles, tiles_x, tex_w, tex_h, &x, &y)) return;
    const int i = image_index(x, y, tex_w);
    if (pos_tex[i].w >= 1.0f) {  // on an island: unchanged
        dst[i] = src[i];
        return;
    }
    const int e = edge_texels;
    // coverage at the four diagonal neighbours e texels away (texel centres: nearest = exact)
    const float a00 = image_load_clamped(pos_tex, tex_w, tex_h, x - e, y - e).w;
    const float a01 = image_load_clamped(pos_tex, tex_w, tex_h, x - e, y + e).w;
    const float a10 = image_load_clamped(pos_tex, tex_w, tex_h, x + e, y - e).w;
    const float a11 = image_load_clamped(pos_tex, tex_w, tex_h, x + e, y + e).w;
    const float2 dir = (float2)(a10 + a11 - a00 - a01, a01 + a11 - a00 - a10);
    if (dir.x == 0.0f && dir.y == 0.0f) {
        dst[i] = src[i];
        return;
    }
    const float2 uv = image_uv(x, y, tex_w, tex_h) + normalize(dir) * (float2)((float)e / tex_w, (float)e / tex_h);
    dst[i] = image_sample_bilinear(src, tex_w, tex_h, uv);
}

// A texel of `src` as 8-bit colour: round(clamp(c, 0, 1) * 255), the conversion GL applies to a float written to an
// RGBA8 texture. The view reads this back (4 bytes a texel instead of 16) and writes it straight into its texture.
__kernel void CanvasToRGBA8(__global const float4* src, int count, __global uchar4* rgba8) {
    const int i = get_global_id(0);
    if (i < count) rgba8[i] = convert_uchar4_sat_rte(src[i] * 255.0f);  // _sat: clamped to [0, 255], NaN -> 0
}
