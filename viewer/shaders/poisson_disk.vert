#version 430 core
// CircleGeometry.shader (vol.4 ch.7), vertex part, instanced path: one quad per sample (instance), scaled to the
// drawn radius. The geometry-shader path (poisson_disk_points.vert + .geom) builds the same quad.
in vec2 in_corner;
// per instance
in vec2 in_center;
in vec4 in_color;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float radius;

out vec2 g_corner;
out vec4 g_color;

void main() {
    g_corner = in_corner;
    g_color = in_color;
    gl_Position = m_proj * m_view * vec4(in_center + in_corner * radius, 0.0, 1.0);
}
