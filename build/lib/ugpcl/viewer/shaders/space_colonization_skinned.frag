#version 430 core
// SkinnedTubularEdgeStandard.shader (vol.4 ch.1 section 1.4), surface part: Standard material albedo 0.726,
// smoothness 0.5, emission (2, 2, 2) fading with growth: smoothstep(1, 0, t), so fresh tips glow and then cool.
// Unity's Standard (PBR) shading becomes Blinn-Phong under the scene's directional light; no post-processing, so
// the result is clamped.
in vec3 g_normal;
in vec3 g_world;
in float g_t;

uniform vec3 eye;
uniform vec3 albedo;
uniform float smoothness;
uniform vec3 emission;
uniform vec3 light_direction;  // the way the light travels, world (Unity) space
uniform float light_intensity;
uniform vec3 ambient;

out vec4 f_color;

void main() {
    vec3 n = normalize(g_normal);
    vec3 l = -normalize(light_direction);
    vec3 v = normalize(eye - g_world);
    if (dot(n, v) < 0.0) n = -n;  // tubes are thin: light the side the camera sees
    float diffuse = max(dot(n, l), 0.0) * light_intensity;
    float shininess = exp2(10.0 * smoothness + 1.0);
    float specular = diffuse > 0.0 ? pow(max(dot(n, normalize(l + v)), 0.0), shininess) * smoothness : 0.0;
    vec3 color = albedo * (ambient + diffuse) + vec3(specular) + emission * smoothstep(1.0, 0.0, g_t);
    f_color = vec4(min(color, vec3(1.0)), 1.0);
}
