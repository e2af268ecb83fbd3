#version 430 core
// The character's mesh, skinned as Unity's SkinnedMeshRenderer does with one bone per vertex: the same matrices
// (bone @ bind pose) that the Animate kernel applies to the nodes.
in vec3 in_position;
in int in_bone;
uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 skin[12];

out vec3 v_world;

void main() {
    vec4 world = skin[in_bone] * vec4(in_position, 1.0);
    v_world = world.xyz;
    gl_Position = m_proj * m_view * world;
}
