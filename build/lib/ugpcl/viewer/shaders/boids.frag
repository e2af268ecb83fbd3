#version 430 core
// BoidsRender.shader (vol.1 ch.3), surface part: white Standard material (smoothness 0.5) -> Blinn-Phong.
#include "lighting.glsl"
in vec3 v_world;
in vec3 v_normal;
in float v_speed;

uniform vec3 eye;
uniform bool color_by_speed;
uniform float max_speed;

out vec4 f_color;

void main() {
    vec3 albedo = vec3(1.0);
    if (color_by_speed) albedo = mix(vec3(0.2, 0.45, 1.0), vec3(1.0, 0.45, 0.1), clamp(v_speed / max_speed, 0.0, 1.0));
    f_color = vec4(blinn_phong(albedo, v_normal, eye - v_world, 0.5), 1.0);
}
