#version 430 core
// Particle.shader (vol.1 ch.5), geometry part: each point becomes a camera-facing quad (billboard, fig. 5.7) of
// half-size particle_radius; the book builds its corners with _InverseMatrix, here the rows of m_view.
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float particle_radius;

in float v_value[];
out vec2 g_uv;
out float g_value;

void main() {
    vec3 right = vec3(m_view[0][0], m_view[1][0], m_view[2][0]);  // camera axes in world space
    vec3 up = vec3(m_view[0][1], m_view[1][1], m_view[2][1]);
    vec3 centre = gl_in[0].gl_Position.xyz;
    for (int k = 0; k < 4; k++) {
        vec2 uv = vec2(k & 1, k >> 1);  // (0,0) (1,0) (0,1) (1,1): one triangle strip
        vec3 corner = centre + particle_radius * ((2.0 * uv.x - 1.0) * right + (2.0 * uv.y - 1.0) * up);
        gl_Position = m_proj * m_view * vec4(corner, 1.0);
        g_uv = uv;
        g_value = v_value[0];
        EmitVertex();
    }
    EndPrimitive();
}
