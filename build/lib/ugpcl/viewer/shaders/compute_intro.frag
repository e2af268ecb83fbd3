#version 430 core
// SampleScene_Texture (vol.1 ch.2): the texture as it is, no lighting, so the 1/512 gradient steps stay exact.
uniform sampler2D gradient;
in vec2 v_uv;
out vec4 f_color;

void main() {
    f_color = texture(gradient, v_uv);
}
