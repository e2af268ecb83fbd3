#version 430 core
// DebugRenderShader.shader (vol.4 ch.3), mass points, geometry part: each point becomes a camera-facing quad of
// half-size particle_size (book: _ParticleSize 0.005), built in view space.
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;
in vec3 v_world[];
uniform mat4 m_proj;
uniform mat4 m_view;
uniform float particle_size;

out vec2 g_uv;

void main() {
    vec4 center = m_view * vec4(v_world[0], 1.0);
    for (int i = 0; i < 4; i++) {
        vec2 corner = vec2(i & 1, i >> 1);  // (0,0) (1,0) (0,1) (1,1): a triangle strip
        g_uv = corner;
        gl_Position = m_proj * (center + vec4((corner * 2.0 - 1.0) * particle_size, 0.0, 0.0));
        EmitVertex();
    }
    EndPrimitive();
}
