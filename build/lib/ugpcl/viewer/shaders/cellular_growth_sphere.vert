#version 430 core
// ParticleSphere.shader (CellularGrowthSphere, vol.3 ch.4): each particle's quad faces the camera (built in view
// space) and is shaded as a sphere in the fragment shader.
#include "cellular_growth.glsl"
in vec2 in_corner;  // quad corner, -0.5 .. 0.5

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float size;

out vec2 v_uv;
out vec3 v_center;  // view space
out float v_radius;
out vec3 v_color;

void main() {
    Particle p = particles[gl_InstanceID];
    float radius = (p.alive != 0u ? 1.0 : 0.0) * p.radius * size;  // the quad is radius x 2 x size wide
    vec4 center = m_view * vec4(p.position, 0.0, 1.0);
    v_uv = in_corner + 0.5;
    v_center = center.xyz;
    v_radius = radius;
    v_color = particle_color(gl_InstanceID);
    gl_Position = m_proj * vec4(center.xyz + vec3(in_corner * 2.0 * radius, 0.0), 1.0);
}
