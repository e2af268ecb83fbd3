#version 430 core
// Attraction points (no book shader: the book shows them only in its figures; the blog draws GL_POINTS).
in vec3 in_position;
uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;
uniform float point_size;  // pixels

void main() {
    gl_Position = m_proj * m_view * m_model * vec4(in_position, 1.0);
    gl_PointSize = point_size;
}
