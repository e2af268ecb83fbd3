#version 430 core
// SampleScene_Texture (vol.1 ch.2): a quad showing a texture written by the compute kernels (Unlit/Texture).
in vec3 in_position;
in vec2 in_uv;
uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;
out vec2 v_uv;

void main() {
    v_uv = in_uv;
    gl_Position = m_proj * m_view * m_model * vec4(in_position, 1.0);
}
