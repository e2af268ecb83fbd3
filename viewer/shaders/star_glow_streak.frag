#version 430 core
// StarGlow.shader pass 2 (vol.4 ch.4, STEP 2): 4 taps along the streak direction, step = dir * power texels, tap j
// weighted by attenuation^(power * j) and saturated (the book's saturate(tex2D(...) * pow(...))). The book's
// vertex stage computes power and offset once; here the host passes them. OpenCL twin: Streak.

uniform sampler2D source;
uniform vec2 step_uv;   // dir * power / (w, h)
uniform vec4 weights;   // attenuation^(power * j), j = 0..3
in vec2 uv;
out vec4 fragColor;

void main() {
    vec4 sum = vec4(0.0);
    for (int j = 0; j < 4; j++) {
        sum += clamp(texture(source, uv + float(j) * step_uv) * weights[j], 0.0, 1.0);
    }
    fragColor = sum;
}
