#version 430 core
// Coordinates pass (viewer/postfx.py tests, GL twin of image_uv in clkernels/include/image.h): each pixel writes the
// uv of the shared vertex stage and its own window coordinates (x + 0.5, y + 0.5).

in vec2 uv;
out vec4 fragColor;

void main() {
    fragColor = vec4(uv, gl_FragCoord.xy);
}
