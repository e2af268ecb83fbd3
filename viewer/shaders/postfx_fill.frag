#version 430 core
// Constant-colour pass (viewer/postfx.py tests): every pixel gets `color`, to check blend states on known colours.

uniform vec4 color;
out vec4 fragColor;

void main() {
    fragColor = color;
}
