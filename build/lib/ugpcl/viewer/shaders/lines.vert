#version 430 core
// Debug lines (no book shader; Unity draws these as editor gizmos): world-space segments in one colour.
in vec3 in_position;
uniform mat4 m_proj;
uniform mat4 m_view;

void main() {
    gl_Position = m_proj * m_view * vec4(in_position, 1.0);
}
