#version 430 core
// GPUClothSimulation.DrawSimulationBufferOnGUI (vol.4 ch.3): one simulation buffer drawn as a screen quad.
in vec2 in_corner;
uniform vec4 rect;  // x, y, width, height in normalised device coordinates

out vec2 v_uv;

void main() {
    v_uv = in_corner;
    gl_Position = vec4(rect.xy + in_corner * rect.zw, 0.0, 1.0);
}
