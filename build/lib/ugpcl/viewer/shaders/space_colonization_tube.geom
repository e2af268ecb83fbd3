#version 430 core
// TubularEdge.shader (vol.4 ch.1), geometry stage: each segment p0 -> p1 becomes a capsule: a 5-sided prism (6 ring
// samples, the first repeated last) and a hemispherical cap at p1 (6 rows x 6 columns). 12 + 72 = 84 vertices: the
// book declares maxvertexcount(64), so D3D dropped the cap's last rows; here the cap is complete. Outputs: 4 + 3 + 3
// + 1 = 11 components x 84 = 924 <= 1024 (GL_MAX_GEOMETRY_TOTAL_OUTPUT_COMPONENTS minimum).
// The ring frame follows the view direction at p0 (t = tangent, n = towards the eye, bn = t x n), as the book; n and
// bn are normalised and fall back to another axis when the segment points at the eye (the book's cross is 0 there).
layout(lines) in;
layout(triangle_strip, max_vertices = 84) out;

in vec3 v_world[];
in float v_t[];

uniform mat4 m_proj;
uniform mat4 m_view;
uniform vec3 eye;
uniform float thickness;  // world units (book: _Thickness)

out vec3 g_normal;
out vec3 g_world;
out float g_t;  // node growth, interpolated from the a end to the b end

const float TWO_PI = 6.28318530718;
const float HALF_PI = 1.57079632679;
const int ROWS = 6, COLS = 6;

void emit(vec3 position, vec3 normal, float t) {
    g_normal = normal;
    g_t = t;
    g_world = position;
    gl_Position = m_proj * m_view * vec4(position, 1.0);
    EmitVertex();
}

void main() {
    vec3 p0 = v_world[0], p1 = v_world[1];
    vec3 d = p1 - p0;
    if (dot(d, d) < 1e-14) return;  // a child that has not started growing (t = 0): nothing to draw
    vec3 t = normalize(d);
    vec3 bn = cross(t, normalize(eye - p0));
    if (dot(bn, bn) < 1e-8) bn = cross(t, abs(t.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0));
    bn = normalize(bn);
    vec3 n = cross(t, bn);

    for (int i = 0; i < COLS; i++) {  // the sides
        float r = float(i) / float(COLS - 1) * TWO_PI;
        vec3 normal = normalize(n * cos(r) + bn * sin(r));
        emit(p0 + normal * thickness, normal, v_t[0]);
        emit(p1 + normal * thickness, normal, v_t[1]);
    }
    EndPrimitive();

    for (int row = 0; row < ROWS; row++) {  // the cap at p1, ring by ring towards the pole
        float s0 = sin(float(row) / float(ROWS) * HALF_PI);
        float s1 = sin(float(row + 1) / float(ROWS) * HALF_PI);
        for (int col = 0; col < COLS; col++) {
            float r = float(col) / float(COLS - 1) * TWO_PI;
            vec3 ring = n * cos(r) + bn * sin(r);
            vec3 n0 = normalize(ring * (1.0 - s0) + t * s0);
            vec3 n1 = normalize(ring * (1.0 - s1) + t * s1);
            emit(p1 + n0 * thickness, n0, v_t[1]);
            emit(p1 + n1 * thickness, n1, v_t[1]);
        }
        EndPrimitive();
    }
}
