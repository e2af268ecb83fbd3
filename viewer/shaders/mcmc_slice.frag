#version 430 core
// Density D / max D: positive warm and opaque-ish, negative blue and faint (Metropolis never stays there).
in vec2 v_uv;

uniform sampler2D density_map;
uniform float inverse_max;

out vec4 f_color;

void main() {
    float d = texture(density_map, v_uv).r * inverse_max;
    vec3 warm = mix(vec3(0.25, 0.05, 0.3), vec3(1.0, 0.85, 0.2), clamp(d, 0.0, 1.0));
    f_color = d > 0.0 ? vec4(warm, 0.25 + 0.6 * clamp(d, 0.0, 1.0)) : vec4(0.1, 0.2, 0.8, 0.15 * clamp(-d, 0.0, 1.0));
}
