#version 430 core
// The sample's Standard material (smoothness 0.5, metallic 0) -> Blinn-Phong under Unity's default light.
#include "lighting.glsl"
in vec3 v_world;
in vec3 v_normal;
in vec3 v_color;

uniform vec3 eye;

out vec4 f_color;

void main() { f_color = vec4(blinn_phong(v_color, v_normal, eye - v_world, 0.5), 1.0); }
