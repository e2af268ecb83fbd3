// lighting.glsl: the light of the book's scenes, shaded Blinn-Phong.
// Unity's default directional light (rotation 50, -30, 0) travels along LIGHT_DIRECTION with LIGHT_COLOR; the
// default ambient is AMBIENT. The Standard material's smoothness maps to the Blinn-Phong exponent below.
const vec3 LIGHT_DIRECTION = vec3(-0.321, -0.766, 0.557);
const vec3 LIGHT_COLOR = vec3(1.0, 0.957, 0.839);
const vec3 AMBIENT = vec3(0.212, 0.227, 0.259);

// albedo lit by the sun and the ambient; normal and to_eye in world space, normalised here.
vec3 blinn_phong(vec3 albedo, vec3 normal, vec3 to_eye, float smoothness) {
    vec3 n = normalize(normal);
    vec3 l = -normalize(LIGHT_DIRECTION);  // towards the light
    vec3 h = normalize(l + normalize(to_eye));
    float diffuse = max(dot(n, l), 0.0);
    float shininess = exp2(10.0 * smoothness + 1.0);  // smoothness 0.5 -> 64
    float specular = diffuse > 0.0 ? pow(max(dot(n, h), 0.0), shininess) * smoothness : 0.0;
    return albedo * (AMBIENT + LIGHT_COLOR * diffuse) + LIGHT_COLOR * specular;
}
