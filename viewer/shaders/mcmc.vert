#version 430 core
// MCMC3d demo (vol.1 ch.8): one instanced cube (the sample's Resource/cube1..9, scale 0.3) per emitted state,
// coloured by its chain's material (mat1..mat9).
in vec3 in_position;
in vec3 in_normal;
// per instance
in vec3 in_offset;
in vec3 in_color;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float cube_size;

out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;

void main() {
    v_world = in_position * cube_size + in_offset;
    v_normal = in_normal;
    v_color = in_color;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
}
