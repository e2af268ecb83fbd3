#version 430 core
// ClothSurface.shader (vol.4 ch.3), surface part: Standard material (metallic 0, smoothness 0.5) with Cull Off,
// approximated by Blinn-Phong; the back face is lit with the flipped normal (two-sided lighting). The sphere
// collider's material uses the same shader with its own albedo.
#include "lighting.glsl"
in vec3 v_world;
in vec3 v_normal;

uniform vec3 eye;
uniform vec3 albedo;
uniform float smoothness;

out vec4 f_color;

void main() {
    vec3 to_eye = eye - v_world;
    vec3 normal = normalize(v_normal);
    if (dot(normal, to_eye) < 0.0) normal = -normal;  // seen from behind: light the side facing the eye
    f_color = vec4(blinn_phong(albedo, normal, to_eye, smoothness), 1.0);
}
