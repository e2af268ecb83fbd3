#version 430 core
// Text overlay panel: the Pillow-rendered RGBA text image.
uniform sampler2D text_image;
in vec2 v_uv;
out vec4 f_color;

void main() {
    f_color = texture(text_image, v_uv);
}
