#version 430 core
// CircleGeometry.shader (vol.4 ch.7), fragment part: a flat disc inside the quad (the sample: unlit white), with
// a one-pixel soft rim; outline > 0 draws only a ring of that width (the active samples).
in vec2 g_corner;
in vec4 g_color;
out vec4 f_color;

uniform float outline;

void main() {
    float d = length(g_corner);
    float edge = fwidth(d);
    float alpha = 1.0 - smoothstep(1.0 - edge, 1.0, d);
    if (outline > 0.0) alpha *= smoothstep(1.0 - outline - edge, 1.0 - outline, d);
    if (alpha <= 0.0) discard;
    f_color = vec4(g_color.rgb, g_color.a * alpha);
}
