#version 430 core
// The chapter's three materials (ProceduralModelingMaterial): Standard, approximated as white Lambert under the
// scenes' sun plus ambient (the Standard material's highlights and reflections are off); UV.shader: (u, v, 0);
// Normal.shader: (n + 1) / 2 of the object-space normal. ProceduralTree.cginc's growth clip: clip(_T - uv.y).
#include "lighting.glsl"
in vec3 v_normal;
centroid in vec2 v_uv;  // sampled inside the triangle, so the growth clip holds at grazed pixels' edges too

uniform int material;  // 0 Standard, 1 UV, 2 Normal
uniform float grow_t;  // _T
uniform vec3 albedo;

out vec4 f_color;

void main() {
    if (v_uv.y > grow_t) discard;
    vec3 n = normalize(v_normal);
    if (material == 1) {
        f_color = vec4(v_uv, 0.0, 1.0);
    } else if (material == 2) {
        f_color = vec4((n + 1.0) * 0.5, 1.0);
    } else {
        float diffuse = max(dot(n, -normalize(LIGHT_DIRECTION)), 0.0);
        f_color = vec4(albedo * (AMBIENT + LIGHT_COLOR * diffuse), 1.0);
    }
}
