#version 430 core
// The OpenCL path's triangles (PolygonizeAppend / GenerateTriangles) drawn as a plain mesh, with the transform of
// the book's geom_light (_Matrix, then the camera); also the floor plane. Fragment: marching_cubes.frag.
in vec3 in_position;  // object space
in vec3 in_normal;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;

out vec3 g_world;
out vec3 g_normal;

void main() {
    vec4 world = m_model * vec4(in_position, 1.0);
    g_world = world.xyz;
    g_normal = mat3(m_model) * in_normal;  // a rotation: no inverse transpose needed
    gl_Position = m_proj * m_view * world;
}
