#version 430 core
// Sampling pass (viewer/postfx.py tests, GL twin of image_sample_bilinear in clkernels/include/image.h): each pixel
// samples `source` with its filter and wrap mode at the uv stored in the same texel of `coords`.

uniform sampler2D source;
uniform sampler2D coords;
out vec4 fragColor;

void main() {
    fragColor = texture(source, texelFetch(coords, ivec2(gl_FragCoord.xy), 0).xy);
}
