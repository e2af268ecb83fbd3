#version 430 core
// Sample.shader's full-screen pass (vol.1 ch.4, RenderEffect): a quad over the grid, w x h cells in world units.
in vec2 in_position;
in vec2 in_uv;
uniform mat4 m_proj;
uniform mat4 m_view;
out vec2 v_uv;

void main() {
    v_uv = in_uv;
    gl_Position = m_proj * m_view * vec4(in_position, 0.0, 1.0);
}
