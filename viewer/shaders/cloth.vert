#version 430 core
// ClothSurface.shader (vol.4 ch.3), vertex part: the mesh's vertex i = y * W + x takes its position and normal from
// the simulation's buffers (book: tex2Dlod of _PositionBuffer / _NormalBuffer at uv = (x, y) / (res - 1), point
// filtered; texelFetch reads the same texel without the half-texel rounding). Both come packed in one texel
// (PackSurface in clkernels/cloth.cl): xyz = the position's float bits, w = the normal as round(n * 511) + 511 in
// 10 bits a component (x in bits 0-9, y 10-19, z 20-29).
uniform usampler2D surface;
uniform mat4 m_proj;
uniform mat4 m_view;

out vec3 v_world;
out vec3 v_normal;

void main() {
    int width = textureSize(surface, 0).x;
    uvec4 texel = texelFetch(surface, ivec2(gl_VertexID % width, gl_VertexID / width), 0);
    v_world = uintBitsToFloat(texel.xyz);
    v_normal = (vec3((uvec3(texel.w) >> uvec3(0u, 10u, 20u)) & 1023u) - 511.0) / 511.0;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
}
