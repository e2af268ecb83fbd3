#version 430 core
// CellularGrowth's particle shader (vol.3 ch.4, repository Particle.shader): one quad per particle slot, drawn
// instanced over the whole capacity; a dead slot collapses to a point (scale alive x radius x 2 x size).
#include "cellular_growth.glsl"
in vec2 in_corner;  // quad corner, -0.5 .. 0.5 (book: BuildQuad)

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float size;

out vec2 v_uv;
out vec3 v_color;

void main() {
    Particle p = particles[gl_InstanceID];
    float scale = (p.alive != 0u ? 1.0 : 0.0) * p.radius * 2.0 * size;
    v_uv = in_corner + 0.5;
    v_color = particle_color(gl_InstanceID);
    gl_Position = m_proj * m_view * vec4(p.position + in_corner * scale, 0.0, 1.0);
}
