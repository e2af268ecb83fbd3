#version 430 core
// Edge.shader (vol.4 ch.1), fragment stage: white, drawn additively (Blend One One, ZTest off).
uniform vec4 color;
out vec4 f_color;

void main() {
    f_color = color;
}
