#version 430 core
// Not a book shader: the quad of fig. 6.2 ("a flat plate like this") in one flat colour, no geometry shader.
in vec3 in_position;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;
uniform vec4 color;

out vec4 g_color;

void main() {
    g_color = color;
    gl_Position = m_proj * m_view * m_model * vec4(in_position, 1.0);
}
