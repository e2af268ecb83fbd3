// image.h: float images for the OpenCL twins of full-screen GL passes (host: ugpcl.viewer.postfx).
//
// An image of w x h texels is a `__global float4*` of w * h elements, rows in GL order: row 0 is the BOTTOM row,
// as FloatTarget.read() returns it, so a kernel's output and a pass's output compare element for element (numpy
// mirror: an (h, w, 4) float32 array; flip with [::-1] for image files). Texel (x, y) has its centre at
// uv = ((x + 0.5) / w, (y + 0.5) / h), the uv that viewer/shaders/fullscreen.vert gives the pixel (x, y).
// These are plain buffers, not OpenCL image objects: PoCL and Oclgrind run them, and kernels may read and write
// them freely.
#ifndef UGPCL_IMAGE_H
#define UGPCL_IMAGE_H

// Element of texel (x, y) in a row-major image of width w.
inline int image_index(int x, int y, int w) { return y * w + x; }

// uv of the centre of texel (x, y): the `uv` a full-screen pass sees at that pixel.
inline float2 image_uv(int x, int y, int w, int h) { return (float2)((x + 0.5f) / w, (y + 0.5f) / h); }

// Texel (x, y) with coordinates outside the image clamped to its edge (GL CLAMP_TO_EDGE).
inline float4 image_load_clamped(__global const float4* img, int w, int h, int x, int y) {
    return img[image_index(clamp(x, 0, w - 1), clamp(y, 0, h - 1), w)];
}

// Bilinear sample at uv, as GL_LINEAR with CLAMP_TO_EDGE filters a texture: the four texels around
// p = uv * size - 0.5, each clamped to the edge, weighted by the fraction of p. Outside the image the edge texels
// extend, so any uv is valid.
inline float4 image_sample_bilinear(__global const float4* img, int w, int h, float2 uv) {
    const float2 size = (float2)((float)w, (float)h);
    // Clamping p to [-1, size] changes no result (beyond it every tap is an edge texel) and keeps (int) in range.
    const float2 p = clamp(uv * size - 0.5f, (float2)(-1.0f), size);
    const float2 base = floor(p);
    const float2 t = p - base;
    const int x = (int)base.x, y = (int)base.y;
    const float4 bottom = mix(image_load_clamped(img, w, h, x, y), image_load_clamped(img, w, h, x + 1, y), t.x);
    const float4 top = mix(image_load_clamped(img, w, h, x, y + 1), image_load_clamped(img, w, h, x + 1, y + 1), t.x);
    return mix(bottom, top, t.y);
}

#endif
