#version 430 core
// Grass.shader and SimpleGeometryShader (vol.1 ch.6), fragment part frag() of both: the interpolated vertex colour,
// unlit. Also the fragment stage of grass_strip.vert and grass_flat.vert.
in vec4 g_color;
out vec4 f_color;

void main() {
    f_color = g_color;
}
