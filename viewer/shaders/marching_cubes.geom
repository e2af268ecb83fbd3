#version 430 core
// GPUMarchingCubesRenderStandardMesh.shader (vol.1 ch.7), geom_light(): one invocation per grid cell samples the
// field at the cell's 8 corners, builds the case index (bit k set when value <= _Threashold), places a vertex on
// every cut edge by linear interpolation, takes its normal from the field's gradient (getNormal) and emits up to
// 5 triangles from triangleConnectionTable. The same per-cell arithmetic as clkernels/marching_cubes.cl.
// field_source 0 (the book): Sample() evaluated here, analytically; 1: corners fetched from the 3D texture the
// SampleField kernel wrote, so the triangles are exactly the OpenCL path's.
layout(points) in;
layout(triangle_strip, max_vertices = 15) out;  // [maxvertexcount(15)]: 5 triangles

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;          // _Matrix = TRS(transform): the object turned 180 degrees about Y
uniform int segment_num;       // _SegmentNum (N)
uniform float threshold;       // _Threashold
uniform int field_source;      // 0 analytic Sample (book), 1 the field texture
uniform int normals;           // 0 analytic getNormal (book), 1 differences of the field texture (trilinear)
uniform int shape;             // 0 spheres, 1 kaiware
uniform vec3 radius;           // the three sphere radii at t (host: base + (0.5 sin(8t + 23.365 i) + 0.5) * amplitude)
uniform float twist;           // kaiware twist at t (10 sin(t / 2))
uniform sampler3D field;       // (N+1)^3 R32F, texel (x, y, z) = grid point
uniform isampler2D triangle_table;  // 16 x 256 R32I: triangleConnectionTable
uniform isampler2D edge_flags;      // 256 x 1 R32I: cubeEdgeFlags

flat in ivec3 v_cell[];

out vec3 g_world;
out vec3 g_normal;

const ivec3 vertexOffset[8] = ivec3[8](ivec3(0, 0, 0), ivec3(1, 0, 0), ivec3(1, 1, 0), ivec3(0, 1, 0),
                                       ivec3(0, 0, 1), ivec3(1, 0, 1), ivec3(1, 1, 1), ivec3(0, 1, 1));
const ivec2 edgeConnection[12] = ivec2[12](ivec2(0, 1), ivec2(1, 2), ivec2(2, 3), ivec2(3, 0), ivec2(4, 5),
                                           ivec2(5, 6), ivec2(6, 7), ivec2(7, 4), ivec2(0, 4), ivec2(1, 5),
                                           ivec2(2, 6), ivec2(3, 7));
const float SMOOTH_MAX_K = 14.0;  // smoothMax(result, sp, 14)
const float KAIWARE_SCALE = 0.5;
const float NORMAL_STEP = 1.0;    // getNormal: +-1 cell

// {{{ the book's field (Primitives.cginc, Utils.cginc, Sample)

float smoothMax(float d1, float d2, float k) { return log(exp(k * d1) + exp(k * d2)) / k; }
float sd_sphere(vec3 p, float r) { return length(p) - r; }
float sd_round_box(vec3 q, vec3 size, float r) { return length(max(abs(q) - size * 0.5, 0.0)) - r; }
float sd_box(vec3 q, vec3 size) { return sd_round_box(q, size, 0.0); }
float sd_capsule(vec3 q, vec3 a, vec3 b, float r) {
    vec3 pa = q - a, ba = b - a;
    float h = clamp(dot(pa, ba) / dot(ba, ba), 0.0, 1.0);
    return length(pa - ba * h) - r;
}
float sd_ellipsoid(vec3 q, vec3 r) { return (length(q / r) - 1.0) * min(min(r.x, r.y), r.z); }
vec3 twist_y(vec3 q, float k) {
    float s = sin(k * q.y), c = cos(k * q.y);
    return vec3(c * q.x - s * q.z, q.y, s * q.x + c * q.z);
}

float kaiware_sdf(vec3 q) {
    float d1 = sd_round_box(q, vec3(1.0, 0.8, 1.0), 0.1);
    float d2_0 = sd_round_box(q - vec3(0.0, -0.2, 0.7), vec3(0.8, 0.25, 0.3), 0.1);
    float d2_1 = sd_box(q - vec3(0.0, 0.0, 0.7), vec3(1.1, 0.35, 1.1));
    float d2_2 = sd_box(q - vec3(0.0, -0.4, 0.7), vec3(1.1, 0.35, 1.1));
    float d2_3 = sd_round_box(q - vec3(0.0, -0.2, 0.7), vec3(0.75, 0.1, 0.25), 0.1);
    float d2 = min(min(max(d2_0, d2_1), max(d2_0, d2_2)), d2_3);
    float d3 = min(sd_capsule(q, vec3(0.0, 0.5, 0.0), vec3(0.0, 0.75, 0.0), 0.05),
                   min(sd_ellipsoid(q - vec3(0.2, 0.75, 0.0), vec3(0.25, 0.025, 0.1)),
                       sd_ellipsoid(q - vec3(-0.2, 0.75, 0.0), vec3(0.25, 0.025, 0.1))));
    float d4 = min(sd_capsule(q, vec3(0.2, 0.25, 0.6), vec3(0.4, 0.2, 0.6), 0.03),
                   sd_capsule(q, vec3(-0.2, 0.25, 0.6), vec3(-0.4, 0.2, 0.6), 0.03));
    return max(min(min(d1, d2), d3), -d4);
}

float Sample(vec3 g) {
    float n = float(segment_num);
    if (any(lessThanEqual(g, vec3(1.0))) || any(greaterThanEqual(g, vec3(n - 1.0)))) return 0.0;
    vec3 pos = g / n;
    if (shape == 1) return 0.5 - KAIWARE_SCALE * kaiware_sdf(twist_y(pos - 0.5, twist) / KAIWARE_SCALE);
    float result = 0.0;
    for (int i = 0; i < 3; i++) {
        float sp = -sd_sphere(pos - vec3(0.5, 0.25 + 0.25 * float(i), 0.5), radius[i]) + 0.5;
        result = smoothMax(result, sp, SMOOTH_MAX_K);
    }
    return result;
}

// }}}

float field_at(ivec3 p) { return texelFetch(field, p, 0).r; }

float field_trilinear(vec3 g) {  // as field_trilinear in marching_cubes.cl
    g = clamp(g, 0.0, float(segment_num));
    ivec3 i = min(ivec3(floor(g)), ivec3(segment_num - 1));
    vec3 f = g - vec3(i);
    float c00 = mix(field_at(i), field_at(i + ivec3(1, 0, 0)), f.x);
    float c10 = mix(field_at(i + ivec3(0, 1, 0)), field_at(i + ivec3(1, 1, 0)), f.x);
    float c01 = mix(field_at(i + ivec3(0, 0, 1)), field_at(i + ivec3(1, 0, 1)), f.x);
    float c11 = mix(field_at(i + ivec3(0, 1, 1)), field_at(i + ivec3(1, 1, 1)), f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

float normal_sample(vec3 g) { return normals == 1 ? field_trilinear(g) : Sample(g); }

vec3 getNormal(vec3 g) {  // S(p - h) - S(p + h): minus the gradient, out of the high-density region
    const vec3 h = vec3(NORMAL_STEP, 0.0, 0.0);
    return vec3(normal_sample(g - h.xyz) - normal_sample(g + h.xyz),
                normal_sample(g - h.yxz) - normal_sample(g + h.yxz),
                normal_sample(g - h.yzx) - normal_sample(g + h.yzx));
}

void main() {
    ivec3 c = v_cell[0];
    float cubeValue[8];
    int flagIndex = 0;
    for (int k = 0; k < 8; k++) {
        ivec3 p = c + vertexOffset[k];
        cubeValue[k] = field_source == 1 ? field_at(p) : Sample(vec3(p));
        if (cubeValue[k] <= threshold) flagIndex |= 1 << k;
    }
    int edgeFlags = texelFetch(edge_flags, ivec2(flagIndex, 0), 0).r;
    if (edgeFlags == 0) return;  // entirely inside or outside

    float scale = 1.0 / float(segment_num);  // _Scale
    vec3 edgeVertices[12];
    vec3 edgeNormals[12];
    for (int e = 0; e < 12; e++) {
        edgeVertices[e] = vec3(0.0);
        edgeNormals[e] = vec3(0.0, 1.0, 0.0);
        if ((edgeFlags & (1 << e)) == 0) continue;
        int a = edgeConnection[e].x, b = edgeConnection[e].y;
        if (e == 2 || e == 3 || e == 6 || e == 7) {  // these edges run downward: interpolate from the lower corner
            int swap = a;
            a = b;
            b = swap;
        }
        float dv = cubeValue[b] - cubeValue[a];
        float offset = dv != 0.0 ? (threshold - cubeValue[a]) / dv : 0.5;  // getOffset
        vec3 g = vec3(c + vertexOffset[a]) + offset * vec3(vertexOffset[b] - vertexOffset[a]);
        edgeVertices[e] = g * scale - 0.5;  // _HalfSize = 0.5
        vec3 n = getNormal(g);
        edgeNormals[e] = dot(n, n) > 0.0 ? normalize(n) : vec3(0.0);
    }
    for (int i = 0; i < 5; i++) {
        if (texelFetch(triangle_table, ivec2(3 * i, flagIndex), 0).r < 0) break;
        vec3 p[3], n[3];
        for (int j = 0; j < 3; j++) {
            int e = texelFetch(triangle_table, ivec2(3 * i + j, flagIndex), 0).r;
            p[j] = edgeVertices[e];
            n[j] = edgeNormals[e];
        }
        vec3 face = cross(p[1] - p[0], p[2] - p[0]);
        vec3 fallback = dot(face, face) > 0.0 ? normalize(face) : vec3(0.0, 1.0, 0.0);
        for (int j = 0; j < 3; j++) {
            vec4 world = m_model * vec4(p[j], 1.0);
            g_world = world.xyz;
            g_normal = normalize(mat3(m_model) * (dot(n[j], n[j]) > 0.0 ? n[j] : fallback));
            gl_Position = m_proj * m_view * world;
            EmitVertex();
        }
        EndPrimitive();  // RestartStrip
    }
}
