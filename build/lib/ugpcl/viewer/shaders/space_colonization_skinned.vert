#version 430 core
// SkinnedTubularEdge.hlsl (vol.4 ch.1 section 1.4), vertex stage: as Edge.shader, on the skinned positions
// (`animated`, written by the Animate kernel) instead of the bind-space ones.
struct SkinnedNode {  // clkernels/include/space_colonization.h: 48 bytes, std430 packs it the same
    float px, py, pz, ax, ay, az;
    int index0;
    float t, offset, mass;
    int parent;
    uint alive;  // SkinnedNode.active (a reserved word in GLSL)
};
layout(std430, binding = 0) readonly buffer Nodes { SkinnedNode nodes[]; };
layout(std430, binding = 1) readonly buffer Edges { ivec2 edges[]; };

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;

out vec3 v_world;
out float v_t;

void main() {
    ivec2 e = edges[gl_InstanceID];
    SkinnedNode a = nodes[e.x];
    SkinnedNode b = nodes[e.y];
    vec3 ap = vec3(a.ax, a.ay, a.az);
    vec3 bp = ap + (vec3(b.ax, b.ay, b.az) - ap) * b.t;
    vec4 world = m_model * vec4(gl_VertexID == 0 ? ap : bp, 1.0);
    v_world = world.xyz;
    v_t = gl_VertexID == 0 ? a.t : b.t;
    gl_Position = m_proj * m_view * world;
}
