#version 430 core
// A paintable object of vol.1 ch.10: object-space mesh, its paint layout uv, placed by m_model (the sample's O2W).
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;

out vec3 v_normal;
out vec3 v_position;
out vec2 v_uv;

void main() {
    vec4 world = m_model * vec4(in_position, 1.0);
    v_position = world.xyz;
    v_normal = mat3(m_model) * in_normal;  // uniform scale: the 3x3 is enough
    v_uv = in_uv;
    gl_Position = m_proj * m_view * world;
}
