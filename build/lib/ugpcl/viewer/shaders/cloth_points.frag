#version 430 core
// DebugRenderShader.shader (vol.4 ch.3), mass points, fragment part: a round sprite (discard outside radius 0.5
// in uv), drawn with additive blending (Blend SrcAlpha One).
in vec2 g_uv;
uniform vec4 color;
out vec4 f_color;

void main() {
    if (length(g_uv - 0.5) > 0.5) discard;
    f_color = color;
}
