#version 430 core
// The vertex stage every full-screen pass shares (viewer/postfx.py): one triangle that covers the viewport, built
// from gl_VertexID alone (no vertex buffer). uv is (0, 0) at the bottom-left corner of the bottom-left pixel and
// (1, 1) at the top-right corner, so at a pixel centre it is the centre of the same texel of a same-sized texture.

out vec2 uv;

void main() {
    vec2 corner = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);  // (0, 0), (2, 0), (0, 2): counter-clockwise
    uv = corner;
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
