#version 430 core
// The figure of vol.4 ch.2 2.5.1 (Figure 2.3) over the limit set: Line1 through (1, 0) and (1 - v, u), Line2
// through (-1, 0) and (-1 - v, u), the central parallelogram between them (0 <= y <= u), Line3 inside it and the
// largest disk (y = u inverted in the unit circle). Drawn where the kernels test points: at the pixel centre's world
// point, inverted in mode 2, so the lines bend with the picture. Blended over kleinian.frag with alpha.
#include "kleinian.h"

uniform ivec2 resolution;
uniform vec2 t;
uniform float scale;
uniform vec2 offset;
uniform vec4 circle;
uniform int mode;
uniform float line_width;  // pixels

out vec4 fragColor;

// 1 on the zero set of f (within line_width / 2 pixels), 0 away from it: |f| over its change per pixel.
float stroke(float f) { return clamp(0.5 * line_width + 0.5 - abs(f) / max(fwidth(f), 1e-30), 0.0, 1.0); }

vec4 over(vec4 below, vec3 color, float alpha) { return vec4(mix(below.rgb, color, alpha), max(below.a, alpha)); }

void main() {
    const ivec2 pixel = ivec2(gl_FragCoord.xy);
    const vec2 p = kleinian_pixel_point(pixel.x, pixel.y, resolution.x, resolution.y, scale, offset, mode);
    const vec2 q = mode == 2 ? kleinian_circle_inverse(p, circle.xy, circle.w) : p;
    const float u = t.x, v = t.y;
    const float sheared = q.x + v / u * q.y;  // -1 on Line2, +1 on Line1
    const bool in_band = q.y >= 0.0 && q.y <= u;
    const bool in_parallelogram = in_band && abs(sheared) <= 1.0;
    const vec2 disk_centre = vec2(0.0, 0.5 / u);

    vec4 color = vec4(0.0);
    if (in_parallelogram) color = vec4(1.0, 0.6, 0.1, 0.12);  // the parallelogram, filled lightly
    color = over(color, vec3(1.0, 0.6, 0.1), stroke(q.y) * float(abs(sheared) <= 1.0));      // its bottom (y = 0)
    color = over(color, vec3(1.0, 0.6, 0.1), stroke(q.y - u) * float(abs(sheared) <= 1.0));  // its top (y = u)
    color = over(color, vec3(0.85, 0.1, 0.1), stroke(sheared - 1.0));                        // Line1
    color = over(color, vec3(0.1, 0.3, 0.95), stroke(sheared + 1.0));                        // Line2
    color = over(color, vec3(0.0, 0.65, 0.2), stroke(q.y - kleinian_line3(q.x, u, v)) * float(in_parallelogram));
    color = over(color, vec3(0.75, 0.0, 0.75), stroke(length(q - disk_centre) - 0.5 / u));  // largest disk
    fragColor = color;
}
