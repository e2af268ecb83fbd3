#version 430 core
// TubularEdge.shader (vol.4 ch.1), fragment stage: the normal as colour, white * (n * 0.5 + 0.5), opaque.
in vec3 g_normal;
in vec3 g_world;
uniform vec4 color;
out vec4 f_color;

void main() {
    f_color = vec4(color.rgb * (normalize(g_normal) * 0.5 + 0.5), color.a);
}
