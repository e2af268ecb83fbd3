#version 430 core
// Edge.shader / TubularEdge.shader (vol.4 ch.1), vertex stage: one 2-vertex segment per instance = per live edge.
// Edge (a, b) -> nodes; the branch reaches b' = a + (b - a) * b.t, so it extends while the child grows (the book
// writes normalize(dir) * length(dir) * t, which is NaN for a zero-length edge). gl_VertexID 0 -> a, 1 -> b'.
struct Node {  // clkernels/include/space_colonization.h: 32 bytes, std430 packs it the same
    float px, py, pz, t, offset, mass;
    int parent;
    uint alive;  // Node.active (a reserved word in GLSL)
};
layout(std430, binding = 0) readonly buffer Nodes { Node nodes[]; };
layout(std430, binding = 1) readonly buffer Edges { ivec2 edges[]; };

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;

out vec3 v_world;
out float v_t;  // growth of this end's node (the skinned scene's glow)

void main() {
    ivec2 e = edges[gl_InstanceID];
    Node a = nodes[e.x];
    Node b = nodes[e.y];
    vec3 ap = vec3(a.px, a.py, a.pz);
    vec3 bp = ap + (vec3(b.px, b.py, b.pz) - ap) * b.t;
    vec4 world = m_model * vec4(gl_VertexID == 0 ? ap : bp, 1.0);
    v_world = world.xyz;
    v_t = gl_VertexID == 0 ? a.t : b.t;
    gl_Position = m_proj * m_view * world;
}
