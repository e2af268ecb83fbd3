#version 430 core
// TessellationSurface.shader's surf (vol.4 ch.6) lit by Unity's legacy BlinnPhong model (UnityBlinnPhongLight):
//   c = albedo * light * max(N.L, 0) + light * _SpecColor * pow(max(N.H, 0), _Specular * 128) * _Gloss
// albedo = _MainTex (white) * _Color (the scene's black): only the specular shows, on the camera's white clear.
// N: the plane's interpolated normal (book lighting) or the normal of the displaced height field (height_normals),
// then bent by the normal map in tangent space (UnpackNormal(tex2D(_NormalMap, uv))). normal.tga is not in the
// repository: the view binds a flat map, Unity's "bump" default, so the bend is zero until someone binds another.
in vec3 v_world;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in float v_level;
out vec4 f_color;

uniform vec3 eye;              // _WorldSpaceCameraPos
uniform vec3 light_direction;  // the direction the light travels, world space
uniform vec3 light_color;      // colour * intensity (_LightColor0)
uniform vec3 albedo;           // _Color
uniform vec3 spec_color;       // _SpecColor
uniform float specular;        // _Specular
uniform float gloss;           // _Gloss
uniform bool height_normals;
uniform sampler2D displacement_map;
uniform sampler2D normal_map;  // _NormalMap: tangent-space normals packed as 0.5 + 0.5 * n
uniform float displacement;
uniform bool negative;
uniform vec3 plane_du;  // world-space d(position)/du of the undisplaced plane
uniform vec3 plane_dv;  // world-space d(position)/dv
uniform bool show_levels;
uniform bool shadows;           // the light's shadows (the sample: addshadow fullforwardshadows, light shadows on)
uniform sampler2D shadow_map;   // depth of the displaced plane seen from the light (tessellation_shadow.frag)
uniform mat4 light_view_proj;   // world -> the shadow map's clip space (orthographic along the light)
uniform float shadow_bias;      // depth offset against self-shadowing, in shadow-map depth units

// Fraction of the light reaching `world`: 3 x 3 samples of the shadow map (soft edges, as Unity's soft shadows).
float light_reaching(vec3 world) {
    vec4 clip = light_view_proj * vec4(world, 1.0);
    vec3 p = clip.xyz / clip.w * 0.5 + 0.5;
    if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(1.0)))) return 1.0;  // outside the map: lit
    vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
    float lit = 0.0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++)
            lit += p.z - shadow_bias <= texture(shadow_map, p.xy + vec2(dx, dy) * texel).r ? 1.0 : 0.0;
    return lit / 9.0;
}

vec3 heat(float t) { return clamp(vec3(3.0 * t, 3.0 * t - 1.0, 3.0 * t - 2.0), 0.0, 1.0); }

void main() {
    vec3 n = normalize(v_normal);
    if (height_normals) {  // surface p(u, v) = plane(u, v) + n * h(u, v): normal = dp/du x dp/dv
        vec2 texel = 1.0 / vec2(textureSize(displacement_map, 0));
        float scale = negative ? -displacement : displacement;
        float hu = (texture(displacement_map, v_uv + vec2(texel.x, 0.0)).r -
                    texture(displacement_map, v_uv - vec2(texel.x, 0.0)).r) / (2.0 * texel.x) * scale;
        float hv = (texture(displacement_map, v_uv + vec2(0.0, texel.y)).r -
                    texture(displacement_map, v_uv - vec2(0.0, texel.y)).r) / (2.0 * texel.y) * scale;
        vec3 m = normalize(cross(plane_du + n * hu, plane_dv + n * hv));
        n = dot(m, n) < 0.0 ? -m : m;
    }
    vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));  // tangent frame around the chosen normal
    vec3 b = cross(n, t) * v_tangent.w;                              // Unity: binormal = cross(normal, tangent) * w
    vec3 bend = texture(normal_map, v_uv).xyz * 2.0 - 1.0;           // UnpackNormal
    n = normalize(t * bend.x + b * bend.y + n * bend.z);
    vec3 l = -normalize(light_direction);
    vec3 h = normalize(l + normalize(eye - v_world));
    float diffuse = max(dot(n, l), 0.0);
    float spec = pow(max(dot(n, h), 0.0), specular * 128.0) * gloss;
    vec3 light = light_color * (shadows ? light_reaching(v_world) : 1.0);  // Unity: the light's atten
    vec3 c = albedo * light * diffuse + light * spec_color * spec;
    if (show_levels) c = mix(c, heat(v_level / 64.0), 0.75);
    f_color = vec4(clamp(c, 0.0, 1.0), 1.0);
}
