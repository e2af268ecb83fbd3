#version 430 core
// The CG world of vol.1 ch.9 as each face camera renders it (the book's five cameras draw its city with Unity):
// the shapes clkernels/multiplane_projection.cl ray-marches, drawn instanced, and the ground as one large quad.
in vec3 in_position;
in vec3 in_normal;
// per instance
in vec3 in_center;
in vec3 in_scale;
in vec3 in_color;

uniform mat4 m_proj;
uniform mat4 m_view;

out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;

void main() {
    v_world = in_center + in_position * in_scale;
    v_normal = in_normal / in_scale;  // inverse transpose of the scale
    v_color = in_color;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
}
