#version 430 core
// CircleGeometry.shader (vol.4 ch.7; fig. 7.7), geometry part: each sample's point becomes a quad around it, and the
// fragment shader cuts the disc out of it (the sample emits a 45-segment fan; a quad draws the same disc with one
// strip of 4 vertices). Corners are computed exactly as the instanced poisson_disk.vert does, so both paths light
// the same pixels.
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float radius;

in vec2 v_center[];
in vec4 v_color[];
out vec2 g_corner;
out vec4 g_color;

void main() {
    for (int k = 0; k < 4; k++) {
        vec2 corner = vec2(2 * (k & 1) - 1, 2 * (k >> 1) - 1);  // (-1,-1) (1,-1) (-1,1) (1,1): the instanced quad
        g_corner = corner;
        g_color = v_color[0];
        gl_Position = m_proj * m_view * vec4(v_center[0] + corner * radius, 0.0, 1.0);
        EmitVertex();
    }
    EndPrimitive();
}
