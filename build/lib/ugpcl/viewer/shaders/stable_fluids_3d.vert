#version 430 core
// Stable fluids 3D (vol.1 ch.4): the book ships Solver3D.compute with no renderer (its 2D scene draws the solver
// texture with Sample.shader). A full-screen triangle: the fragment shader casts one ray per pixel into the volume.
out vec2 v_ndc;

void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));  // (0,0) (2,0) (0,2)
    v_ndc = corner * 2.0 - 1.0;
    gl_Position = vec4(v_ndc, 0.0, 1.0);
}
