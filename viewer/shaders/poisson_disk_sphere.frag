#version 430 core
// SphereGeometry.shader (vol.4 ch.7), fragment part: white with a head-light Lambert term and an ambient floor;
// fragments beyond the clipping slab (clip_z) are dropped to show the interior.
in vec3 v_normal;
in vec4 v_color;
in vec3 v_world;
out vec4 f_color;

uniform vec3 eye;
uniform float clip_z;

void main() {
    if (v_world.z > clip_z) discard;
    vec3 n = normalize(v_normal);
    float lambert = abs(dot(n, normalize(eye - v_world)));
    f_color = vec4(v_color.rgb * (0.25 + 0.75 * lambert), v_color.a);
}
