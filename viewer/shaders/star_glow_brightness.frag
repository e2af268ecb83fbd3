#version 430 core
// StarGlow.shader pass 1 (vol.4 ch.4, STEP 1): the bright part of the source, drawn into a divide-times smaller
// target; one bilinear tap at the small texel's centre. OpenCL twin: Brightness in clkernels/star_glow.cl.

uniform sampler2D source;
uniform float threshold;
uniform float intensity;
in vec2 uv;
out vec4 fragColor;

void main() {
    fragColor = max(texture(source, uv) - threshold, 0.0) * intensity;
}
