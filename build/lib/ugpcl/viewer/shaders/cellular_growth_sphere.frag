#version 430 core
// ParticleSphere.shader, fragment part: a sphere impostor. n.xy from the quad's uv, n.z = sqrt(1 - r^2); the depth
// is written for the surface point; Lambert + Blinn-Phong with the sphere scene's directional light.
in vec2 v_uv;
in vec3 v_center;
in float v_radius;
in vec3 v_color;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform float size;
uniform bool depth_from_size;  // the book pushes the depth by the constant _Size, not by the radius

out vec4 f_color;

const vec3 LIGHT_FORWARD = vec3(-0.069, -0.088, 0.994);  // the scene's directional light (Unity world space)
const float LIGHT_INTENSITY = 1.0;
const vec3 AMBIENT = vec3(0.212, 0.227, 0.259);           // the scene's ambient colour
const vec3 SPECULAR = vec3(0.1);                          // the material's specular colour
const float SMOOTHNESS = 0.8;

void main() {
    vec2 xy = v_uv * 2.0 - 1.0;
    float r2 = dot(xy, xy);
    if (r2 > 1.0) discard;
    vec3 n_view = vec3(xy, sqrt(1.0 - r2));  // towards the eye (GL view space looks along -z)
    float push = depth_from_size ? size : v_radius;
    vec3 surface = v_center + n_view * push;
    vec4 clip = m_proj * vec4(surface, 1.0);
    gl_FragDepth = clip.z / clip.w * 0.5 + 0.5;

    mat3 to_world = transpose(mat3(m_view));  // the view's rotation (and mirror) is orthogonal
    vec3 n = normalize(to_world * n_view);
    vec3 to_eye = normalize(to_world * -(v_center + n_view * v_radius));
    vec3 l = -normalize(LIGHT_FORWARD);
    vec3 h = normalize(l + to_eye);
    float diffuse = max(dot(n, l), 0.0);
    float shininess = exp2(10.0 * SMOOTHNESS + 1.0);
    float specular = diffuse > 0.0 ? pow(max(dot(n, h), 0.0), shininess) : 0.0;
    vec3 color = v_color * (AMBIENT + diffuse * LIGHT_INTENSITY) + SPECULAR * specular * LIGHT_INTENSITY;
    f_color = vec4(color, 1.0);
}
