#version 430 core
// DebugRenderShader.shader (vol.4 ch.3), mass points, vertex part: point i = y * W + x fetches its position (the
// float bits in xyz of PackSurface's texel, as cloth.vert).
uniform usampler2D surface;

out vec3 v_world;

void main() {
    int width = textureSize(surface, 0).x;
    v_world = uintBitsToFloat(texelFetch(surface, ivec2(gl_VertexID % width, gl_VertexID / width), 0).xyz);
}
