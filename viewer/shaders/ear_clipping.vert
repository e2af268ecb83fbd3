#version 430 core
// Ear clipping fill (vol.4 ch.5; the sample draws the mesh with Unity's Standard material and a photo texture):
// the triangles at z = 0 with the planar UVs of CalcUV.
in vec2 in_position;
in vec2 in_uv;

uniform mat4 m_proj;
uniform mat4 m_view;

out vec2 v_uv;

void main() {
    v_uv = in_uv;
    gl_Position = m_proj * m_view * vec4(in_position, 0.0, 1.0);
}
