#version 430 core
// DebugRenderShader.shader (vol.4 ch.3), mass points, vertex part: point i = y * W + x fetches its position.
uniform sampler2D position_buffer;

out vec3 v_world;

void main() {
    int width = textureSize(position_buffer, 0).x;
    v_world = texelFetch(position_buffer, ivec2(gl_VertexID % width, gl_VertexID / width), 0).xyz;
}
