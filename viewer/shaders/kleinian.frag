#version 430 core
// KleinianGroup.shader of vol.4 ch.2 (docs/chapters/13-kleinian.md): the passes frag (mode 0), frag_multisample
// (mode 1) and frag_circle_inverse (mode 2) over the whole viewport. The maths is clkernels/include/kleinian.h, the
// file clkernels/kleinian.cl includes too (viewer/views/kleinian.py serves it to #include).
#include "kleinian.h"

uniform ivec2 resolution;  // viewport size, pixels
uniform vec2 t;            // (u, v)
uniform float scale;
uniform vec2 offset;
uniform vec4 circle;       // centre xy, w = the inversion's radius argument
uniform int iteration;
uniform int mode;
uniform int samples;       // 1 in mode 0
uniform float jitter;
uniform int hash;          // 0 portable, 1 the book's sin hash
uniform vec4 hit_color;
uniform vec4 back_color;

out vec4 fragColor;

void main() {
    const ivec2 pixel = ivec2(gl_FragCoord.xy);  // row 0 = bottom, as the kernel's rows
    const ivec2 r = kleinian_pixel(pixel.x, pixel.y, resolution.x, resolution.y, t, scale, offset, circle.xy, circle.w,
                                   iteration, mode, samples, jitter, hash);
    // as RenderKleinian's pixel_colour: the colour itself where every sample agrees, else the mean
    if (r.x == samples) fragColor = hit_color;
    else if (r.x == 0) fragColor = back_color;
    else fragColor = mix(back_color, hit_color, float(r.x) / float(samples));
}
