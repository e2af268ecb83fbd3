// kleinian.cl: Unity Graphics Programming vol.4 ch.2, "Limit sets of Kleinian groups"
// (docs/chapters/13-kleinian.md). The book has no compute shader: KleinianGroup.shader is a full-screen fragment
// shader with three passes (frag, frag_multisample, frag_circle_inverse). Its core lives in include/kleinian.h,
// which viewer/shaders/kleinian.frag includes too; these kernels only read arguments and write pixels.
// Host: ugpcl/scenes/kleinian.py (Simulation).
// Kernels, in host call order:
//   ClassifyPoints    pts (N, 2) -> hit (N,) 0/1, iters (N,): jos_kleinian of each point (tests, point queries)
//   per frame, adaptive=true only:
//   PixelCentreHits   -> centre_hit (W*H) 0/1 and iters: the test at every pixel's centre (pass 2: inverted), the
//                     one sample per pixel that decides where to supersample
//   every frame:
//   RenderKleinian    -> rgba (W*H float4), hit (samples that hit, ushort), iters: the book's pass `mode` (0 frag,
//                     1 frag_multisample, 2 frag_circle_inverse); with adaptive, pixels whose 3x3 neighbourhood of
//                     centre_hit is uniform keep their centre colour and only the others take `samples` samples
// Build defines: KLEINIAN_DOUBLE (1: `real` is double, cl_khr_fp64, for deep zooms; 0: float as the book).
// Atomics, barriers, local memory: none. Races: none (each work-item writes its own pixel or point; RenderKleinian
// reads centre_hit, which the previous launch wrote).
// Rows are in GL order (row 0 = bottom, image.h); the host flips them for .npz and PNG.
// Differences from the book: the mean of the samples is mix(back, hit, hits / samples) (the book sums colours; the
// same value up to rounding, and exactly the colour itself when every sample agrees); `sum` starts at 0 (the
// book's is uninitialised); the jitter hash is a portable integer hash unless hash=1 (the original sin hash).
#include "image.h"     // image_index: GL row order
#include "kleinian.h"  // jos_kleinian, kleinian_pixel: the core shared with viewer/shaders/kleinian.frag

#define VIEW_ARGS                                                                                                   \
    const int width, const int height, const real u, const real v, const real scale, const real offset_x,           \
        const real offset_y, const real circle_x, const real circle_y, const real circle_w, const int iteration,    \
        const int mode, const int samples, const real jitter, const int hash

// The book's choice between the two colours; a mix only for pixels whose samples disagree.
inline float4 pixel_colour(int hits, int samples, float4 hit_color, float4 back_color) {
    if (hits == samples) return hit_color;
    if (hits == 0) return back_color;
    return mix(back_color, hit_color, (float)hits / (float)samples);
}

__kernel void ClassifyPoints(const __global real* pts, const int n, const real u, const real v, const int iteration,
                             __global uchar* hit, __global int* iters) {
    const int i = get_global_id(0);
    if (i >= n) return;
    const int r = jos_kleinian((real2)(pts[2 * i], pts[2 * i + 1]), (real2)(u, v), iteration);
    hit[i] = r > 0 ? 1 : 0;
    iters[i] = r > 0 ? r : -r;
}

__kernel void PixelCentreHits(__global uchar* centre_hit, __global int* iters, VIEW_ARGS) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= width || y >= height) return;
    const int2 r = kleinian_pixel(x, y, width, height, (real2)(u, v), scale, (real2)(offset_x, offset_y),
                                  (real2)(circle_x, circle_y), circle_w, iteration, mode == 2 ? 2 : 0, 1, 0, hash);
    centre_hit[image_index(x, y, width)] = (uchar)r.x;
    iters[image_index(x, y, width)] = r.y;
}

__kernel void RenderKleinian(__global float4* rgba, __global ushort* hit, __global int* iters,
                             const __global uchar* centre_hit, const int adaptive, const float4 hit_color,
                             const float4 back_color, VIEW_ARGS) {
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= width || y >= height) return;
    const int index = image_index(x, y, width);
    if (adaptive) {
        // uniform 3x3 neighbourhood (clamped at the edges): no boundary nearby, the centre sample stands for all
        const uchar c = centre_hit[index];
        bool uniform = true;
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++)
                uniform &= centre_hit[image_index(clamp(x + dx, 0, width - 1), clamp(y + dy, 0, height - 1), width)] == c;
        if (uniform) {
            rgba[index] = c ? hit_color : back_color;
            hit[index] = (ushort)(c ? samples : 0);
            return;  // iters: PixelCentreHits wrote the centre's
        }
    }
    const int2 r = kleinian_pixel(x, y, width, height, (real2)(u, v), scale, (real2)(offset_x, offset_y),
                                  (real2)(circle_x, circle_y), circle_w, iteration, mode, samples, jitter, hash);
    rgba[index] = pixel_colour(r.x, samples, hit_color, back_color);
    hit[index] = (ushort)r.x;
    if (!adaptive) iters[index] = r.y;
}
