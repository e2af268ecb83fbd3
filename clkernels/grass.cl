// grass.cl: Unity Graphics Programming vol.1 ch.6, "Growing grass with geometry shaders"
// (docs/chapters/06-grass.md).
// The chapter has no compute shader: both samples are vertex -> geometry -> fragment shaders, ported to GLSL in
// viewer/shaders/grass.* and grass_pyramid.*. These kernels are the geometry stage re-done in OpenCL for headless
// runs (.npz, meshes) and tests: one work-item per input triangle writes that triangle's fixed output slots (the
// emission count is constant), so there are no atomics, no local memory and no barriers.
// Kernels, in host call order (one per frame of the scene they belong to):
//   1. GrassExpand     tri, pos, nrm, per-vertex hei/rot/wind, plane models, GrassParams -> blade_pos (B, 7, 3),
//                      blade_col (B, 7, 4), blade_h/blade_rot/blade_wind (B,): Grass.shader geom(), world space
//   2. PyramidExpand   tri, pos, model -> pyr_pos (T, 12, 3), pyr_col (T, 12, 4): SimpleGeometryShader geom()
// Build defines: none. Meshes are packed float triplets read with vload3 (never float3 in a buffer: 16 bytes in
// OpenCL, 12 in numpy). Model matrices are row-major float[16], one per plane.
// Differences from the book: the blade direction normalize((p2 - p0) * (rot - 0.5)) is computed as
// sign(rot - 0.5) * normalize(p2 - p0) with sign -1 when rot is exactly 0.5 (the book's normalize(0) is NaN);
// positions are built in float3 with w = 1 (the book's float4 arithmetic leaves garbage in w that Unity drops).
#include "grass.h"  // GrassParams: 96 B; numpy mirror GRASS_PARAMS_DTYPE

#define BLADE_VERTICES 7     // [maxvertexcount(7)]: one strip of 5 triangles
#define PYRAMID_VERTICES 12  // [maxvertexcount(12)]: 4 separate triangles
#define THIRD 0.33333f       // the book's literal in lerp(_BottomColor, _TopColor, 0.33333f) and the pyramid centroid
#define TWO_THIRDS 0.66666f  // the book's literal in lerp(_BottomColor, _TopColor, 0.66666f)

// UnityObjectToClipPos minus the camera: object -> world with a row-major 4x4 (w = 1).
inline float3 transform_point(__global const float* m, float3 p) {
    return (float3)(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
                    m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                    m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}

// Grass.shader geom(): triangle b % triangles_per_plane of plane b / triangles_per_plane becomes one blade.
__kernel void GrassExpand(__global const uint* tri,          // (T, 3) vertex indices of one plane mesh
                          __global const float* pos,         // (V, 3) object-space positions
                          __global const float* nrm,         // (V, 3) object-space normals
                          __global const float* hei,         // (V,) HeightMap.r at each vertex (vert())
                          __global const float* rot,         // (V,) RotationMap.r
                          __global const float* wind,        // (V,) WindMap.r
                          __global const float* models,      // (P, 16) row-major plane matrices
                          int triangles_per_plane, int blades,
                          __constant GrassParams* p,
                          __global float* blade_pos,         // (B, 7, 3) world-space strip vertices
                          __global float* blade_col,         // (B, 7, 4) vertex colours
                          __global float* blade_h,           // (B,) triangle means of the three maps
                          __global float* blade_rot,
                          __global float* blade_wind) {
    int b = get_global_id(0);
    if (b >= blades) return;
    int plane = b / triangles_per_plane;
    int t = b - plane * triangles_per_plane;
    uint i0 = tri[3 * t], i1 = tri[3 * t + 1], i2 = tri[3 * t + 2];
    float3 p0 = vload3(i0, pos), p1 = vload3(i1, pos), p2 = vload3(i2, pos);

    // the vertex shader's samples, averaged over the triangle
    float height = (hei[i0] + hei[i1] + hei[i2]) / 3.0f;
    float r = (rot[i0] + rot[i1] + rot[i2]) / 3.0f;
    float w = (wind[i0] + wind[i1] + wind[i2]) / 3.0f;

    float3 center = (p0 + p1 + p2) / 3.0f;
    float3 normal = (vload3(i0, nrm) + vload3(i1, nrm) + vload3(i2, nrm)) / 3.0f;  // not normalised (book)

    float bottom_height = height * p->height * p->bottom_height;
    float middle_height = height * p->height * p->middle_height;
    float top_height = height * p->height * p->top_height;
    float bottom_width = p->width * p->bottom_width;
    float middle_width = p->width * p->middle_width;
    float top_width = p->width * p->top_width;

    // book: dir = normalize((p2 - p0) * (rot - 0.5)); the map only picks the side, and 0.5 must not give NaN
    float3 edge = p2 - p0;
    float edge_length = length(edge);
    float3 dir = (r > 0.5f ? 1.0f : -1.0f) * (edge_length > 0.0f ? edge / edge_length : (float3)(0.0f));

    float3 v[BLADE_VERTICES];
    v[0] = center - dir * bottom_width;  // bottom
    v[1] = center + dir * bottom_width;
    v[2] = center - dir * middle_width + normal * bottom_height;  // bottom to middle
    v[3] = center + dir * middle_width + normal * bottom_height;
    v[4] = v[3] - dir * top_width + normal * middle_height;  // middle to top: both built from v[3] (book)
    v[5] = v[3] + dir * top_width + normal * middle_height;
    v[6] = v[5] + dir * top_width + normal * top_height;  // top

    // Bend: object-space +X times sin(_Time).x = sin(time / 20) (wind_time_scale)
    float sway = p->wind_power * w * sin(p->time * p->wind_time_scale);
    v[2].x += sway * p->bottom_bend;
    v[3].x += sway * p->bottom_bend;
    v[4].x += sway * p->middle_bend;
    v[5].x += sway * p->middle_bend;
    v[6].x += sway * p->top_bend;

    float4 bottom = p->bottom_color, top = p->top_color;
    float4 color[4] = {bottom, mix(bottom, top, THIRD), mix(bottom, top, TWO_THIRDS), top};
    __global const float* model = models + 16 * plane;
    for (int k = 0; k < BLADE_VERTICES; k++) {  // stream.Append(o[k]) without RestartStrip: one strip
        vstore3(transform_point(model, v[k]), b * BLADE_VERTICES + k, blade_pos);
        vstore4(color[k / 2], b * BLADE_VERTICES + k, blade_col);  // levels 0 0 1 1 2 2 3
    }
    blade_h[b] = height;
    blade_rot[b] = r;
    blade_wind[b] = w;
}

// SimpleGeometryShader geom(): every triangle becomes a triangular pyramid, apex pushed along object -Z.
__kernel void PyramidExpand(__global const uint* tri,   // (T, 3)
                            __global const float* pos,  // (V, 3) object-space positions
                            __global const float* model,  // (16,) row-major object -> world
                            int triangles, float height,
                            float4 top_color, float4 bottom_color,
                            __global float* pyr_pos,    // (T, 12, 3) world space
                            __global float* pyr_col) {  // (T, 12, 4)
    int t = get_global_id(0);
    if (t >= triangles) return;
    float3 p0 = vload3(tri[3 * t], pos), p1 = vload3(tri[3 * t + 1], pos), p2 = vload3(tri[3 * t + 2], pos);
    float3 c = (float3)(0.0f, 0.0f, -height) + (p0 + p1 + p2) * THIRD;  // book: * 0.33333f

    // bottom (p0, p1, p2), then the sides (p0, p1, c), (p1, p2, c), (p2, p0, c); RestartStrip after each
    float3 v[PYRAMID_VERTICES] = {p0, p1, p2, p0, p1, c, p1, p2, c, p2, p0, c};
    for (int k = 0; k < PYRAMID_VERTICES; k++) {
        vstore3(transform_point(model, v[k]), t * PYRAMID_VERTICES + k, pyr_pos);
        vstore4(k >= 3 && k % 3 == 2 ? top_color : bottom_color, t * PYRAMID_VERTICES + k, pyr_col);
    }
}
