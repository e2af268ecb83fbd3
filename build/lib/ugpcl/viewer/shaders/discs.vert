#version 430 core
// 2D particles (no single book shader: vol.1 ch.5 and vol.3 ch.4 draw particles as instanced sprites):
// one quad per instance, scaled to its radius.
in vec2 in_corner;
// per instance
in vec2 in_center;
in float in_radius;
in vec4 in_color;

uniform mat4 m_proj;
uniform mat4 m_view;

out vec2 v_corner;
out vec4 v_color;

void main() {
    v_corner = in_corner;
    v_color = in_color;
    gl_Position = m_proj * m_view * vec4(in_center + in_corner * in_radius, 0.0, 1.0);
}
