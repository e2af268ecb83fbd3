#version 430 core
// Debug lines: one flat colour.
uniform vec4 color;
out vec4 f_color;

void main() {
    f_color = color;
}
