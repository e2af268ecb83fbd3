#version 430 core
// The floor: grey 0.868 lit by the directional light, darkened where the shadow map says the tubes (and the body)
// are between it and the light; 3 x 3 PCF (the original uses soft shadows, strength 1).
in vec3 v_world;
in vec4 v_light;

uniform vec3 albedo;
uniform vec3 light_direction;
uniform float light_intensity;
uniform vec3 ambient;
uniform bool shadows;
uniform sampler2DShadow shadow_map;
uniform float texel;  // 1 / shadow map size

out vec4 f_color;

float lit_fraction() {
    vec3 p = v_light.xyz / v_light.w * 0.5 + 0.5;
    if (!shadows || any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(1.0)))) return 1.0;
    float sum = 0.0;
    for (int dx = -1; dx <= 1; dx++)
        for (int dy = -1; dy <= 1; dy++) sum += texture(shadow_map, vec3(p.xy + vec2(dx, dy) * texel, p.z - 0.002));
    return sum / 9.0;
}

void main() {
    vec3 n = vec3(0.0, 1.0, 0.0);
    float diffuse = max(dot(n, -normalize(light_direction)), 0.0) * light_intensity * lit_fraction();
    f_color = vec4(min(albedo * (ambient + diffuse), vec3(1.0)), 1.0);
}
