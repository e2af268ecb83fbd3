#version 430 core
// GPUClothSimulation.DrawSimulationBufferOnGUI (vol.4 ch.3): the float texture's xyz shown as colour, clamped to
// [0, 1] as GUI.DrawTexture shows an ARGBFloat RenderTexture. Vertex stage: overlay.vert (a quad placed by rect).
in vec2 v_uv;
uniform sampler2D buffer_texture;
out vec4 f_color;

void main() {
    f_color = vec4(clamp(texture(buffer_texture, v_uv).xyz, 0.0, 1.0), 1.0);
}
