#version 430 core
// ClothSurface.shader (vol.4 ch.3), vertex part: the mesh's vertex i = y * W + x takes its position and normal from
// the simulation's buffers (book: tex2Dlod of _PositionBuffer / _NormalBuffer at uv = (x, y) / (res - 1), point
// filtered; texelFetch reads the same texel without the half-texel rounding).
uniform sampler2D position_buffer;
uniform sampler2D normal_buffer;
uniform mat4 m_proj;
uniform mat4 m_view;

out vec3 v_world;
out vec3 v_normal;

void main() {
    int width = textureSize(position_buffer, 0).x;
    ivec2 texel = ivec2(gl_VertexID % width, gl_VertexID / width);
    v_world = texelFetch(position_buffer, texel, 0).xyz;
    v_normal = texelFetch(normal_buffer, texel, 0).xyz;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
}
