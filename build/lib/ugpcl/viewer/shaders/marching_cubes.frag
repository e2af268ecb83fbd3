#version 430 core
// GPUMarchingCubesRenderStandardMesh.shader (vol.1 ch.7), frag_light(): Unity's deferred Standard PBR with albedo
// _DiffuseColor, _Metallic, _Glossiness and emission _EmissionColor * _EmissionIntensity, approximated forward with
// the suite's light: Blinn-Phong whose diffuse fades and whose highlight takes the albedo as metallic grows.
// The world position is the real one (the book's GS never fills worldPos, so its view direction starts at 0).
#include "lighting.glsl"
in vec3 g_world;
in vec3 g_normal;

uniform vec3 eye;
uniform vec3 diffuse_color;    // _DiffuseColor
uniform float metallic;        // _Metallic
uniform float glossiness;      // _Glossiness (smoothness)
uniform vec3 emission;         // _EmissionColor * _EmissionIntensity
uniform bool shadows;          // the book's shadow-caster pass (Unity soft shadows) on/off
uniform mat4 m_light;          // world -> the shadow map's clip space (orthographic, along the light)
uniform sampler2DShadow shadow_map;

const float SHADOW_BIAS = 0.002;  // depth units of the light's box, ~1/3 of a cell at N = 64

// Fraction of the sun that reaches this point: 3x3 percentage-closer filtering of the shadow map (soft edges).
float sunlight(vec3 n, vec3 l) {
    if (!shadows) return 1.0;
    vec4 clip = m_light * vec4(g_world, 1.0);
    vec3 s = clip.xyz / clip.w * 0.5 + 0.5;
    if (any(lessThan(s, vec3(0.0))) || any(greaterThan(s, vec3(1.0)))) return 1.0;  // outside the light's box
    float bias = SHADOW_BIAS * (1.0 + 2.0 * (1.0 - max(dot(n, l), 0.0)));  // more on slopes facing away
    vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
    float lit = 0.0;
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) lit += texture(shadow_map, vec3(s.xy + vec2(x, y) * texel, s.z - bias));
    return lit / 9.0;
}

out vec4 f_color;

void main() {
    vec3 n = normalize(g_normal);
    vec3 to_eye = normalize(eye - g_world);
    vec3 l = -normalize(LIGHT_DIRECTION);
    vec3 h = normalize(l + to_eye);
    float sun = sunlight(n, l);
    float diffuse = max(dot(n, l), 0.0) * sun;
    float shininess = exp2(10.0 * glossiness + 1.0);  // as blinn_phong: smoothness 0.5 -> 64
    float specular = diffuse > 0.0 ? pow(max(dot(n, h), 0.0), shininess) * glossiness * sun : 0.0;
    vec3 albedo = diffuse_color * (1.0 - 0.5 * metallic);  // metals reflect more than they scatter
    vec3 highlight = mix(vec3(1.0), diffuse_color, metallic);
    vec3 color = albedo * (AMBIENT + LIGHT_COLOR * diffuse) + highlight * LIGHT_COLOR * specular + emission;
    f_color = vec4(color, 1.0);
}
