#version 430 core
// CellularGrowth's edge shader (vol.3 ch.4, repository Edge.shader): one line per edge slot (BuildSegment, drawn
// instanced over the capacity), its ends pulled from the particle buffer by (a, b). The alpha fades springs that
// are stretched beyond twice their rest length (book: _Length = 2); a dead edge collapses to a point.
#include "cellular_growth.glsl"
struct Edge {
    int a;
    int b;
    float fx;
    float fy;
    uint alive;
};
layout(std430, binding = 1) readonly buffer Edges { Edge edges[]; };

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float edge_length;

out float v_alpha;

void main() {
    Edge e = edges[gl_InstanceID];
    Particle pa = particles[e.a];
    Particle pb = particles[e.b];
    float len = max(distance(pa.position, pb.position), 1e-6);
    float alive = e.alive != 0u ? 1.0 : 0.0;
    v_alpha = clamp(edge_length * (pa.radius + pb.radius) / len, 0.0, 1.0) * alive;
    vec2 position = (gl_VertexID == 0 || alive == 0.0) ? pa.position : pb.position;
    gl_Position = m_proj * m_view * vec4(position, 0.0, 1.0);
}
