#version 430 core
// Not a book shader: draws the blades GrassExpand (clkernels/grass.cl) wrote, already in world space, as the
// triangle list blade_tris; with grass.frag it gives the picture the geometry shader gives (the view's Tab key).
in vec3 in_position;
in vec4 in_color;

uniform mat4 m_proj;
uniform mat4 m_view;

out vec4 g_color;

void main() {
    g_color = in_color;
    gl_Position = m_proj * m_view * vec4(in_position, 1.0);
}
