#version 430 core
// The target density on one plane z = const of the lattice (no book shader: the demo shows only the cubes).
in vec2 in_corner;  // (0, 0) .. (1, 1)

uniform mat4 m_proj;
uniform mat4 m_view;
uniform vec4 rect;  // x0, y0, width, height in lattice units
uniform float slice_z;

out vec2 v_uv;

void main() {
    v_uv = in_corner;
    gl_Position = m_proj * m_view * vec4(rect.xy + in_corner * rect.zw, slice_z, 1.0);
}
