#version 430 core
// Particle.shader (vol.1 ch.5), fragment part: sprite texture x _WaterColor, alpha-blended. The book's particle.png
// (a soft white disc) is replaced by its procedural shape: alpha = 1 - smoothstep(0.66, 0.98, r / R).
in vec2 g_uv;
in float g_value;
out vec4 f_color;

uniform vec4 water_color;
uniform int color_mode;  // 0 water, 1 speed, 2 density, 3 pressure

// blue -> cyan -> yellow -> red for the quantity modes
vec3 ramp(float t) {
    vec3 a = vec3(0.0, 0.25, 1.0), b = vec3(0.0, 0.9, 1.0), c = vec3(1.0, 0.9, 0.1), d = vec3(1.0, 0.15, 0.05);
    return t < 0.5 ? mix(a, b, t * 2.0) : t < 0.75 ? mix(b, c, (t - 0.5) * 4.0) : mix(c, d, (t - 0.75) * 4.0);
}

void main() {
    float r = length(g_uv - 0.5) / 0.5;
    float sprite = 1.0 - smoothstep(0.66, 0.98, r);
    if (sprite <= 0.0) discard;
    vec3 rgb = color_mode == 0 ? water_color.rgb : ramp(g_value);
    f_color = vec4(rgb, water_color.a * sprite);
}
