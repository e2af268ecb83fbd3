#version 430 core
// SphereGeometry.shader (vol.4 ch.7), as instancing: a low-poly UV sphere (7 rings x 15 segments) per sample,
// of the drawn radius, with Lambert shading added (the sample draws flat white).
in vec3 in_position;
in vec3 in_normal;
// per instance
in vec3 in_center;
in vec4 in_color;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float radius;

out vec3 v_normal;
out vec4 v_color;
out vec3 v_world;

void main() {
    v_normal = in_normal;
    v_color = in_color;
    v_world = in_center + in_position * radius;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
}
