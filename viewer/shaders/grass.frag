#version 430 core
// Grass.shader (vol.1 ch.6), fragment part frag(): the interpolated vertex colour, unlit.
in vec4 g_color;
out vec4 f_color;

void main() {
    f_color = g_color;
}
