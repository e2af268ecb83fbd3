#version 430 core
// The room of vol.1 ch.9 (Room.cs: one quad per face, its material showing that face camera's RenderTexture).
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;

uniform mat4 m_proj;
uniform mat4 m_view;

out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    gl_Position = m_proj * m_view * vec4(in_position, 1.0);
}
