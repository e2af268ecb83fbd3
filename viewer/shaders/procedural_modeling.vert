#version 430 core
// Procedural modeling (vol.1 ch.1): the generated meshes in Unity's coordinates, placed by m_model (a translation,
// and a scale for the overlay's spheres). Fragment: procedural_modeling.frag.
in vec3 in_position;  // object space
in vec3 in_normal;    // object space: the Normal material shows it as it is
in vec2 in_uv;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;

out vec3 v_normal;
centroid out vec2 v_uv;  // centroid: a pixel a triangle only grazes (MSAA) takes uv from inside it, not extrapolated

void main() {
    v_normal = in_normal;
    v_uv = in_uv;
    gl_Position = m_proj * m_view * m_model * vec4(in_position, 1.0);
}
