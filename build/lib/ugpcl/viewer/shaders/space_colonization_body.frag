#version 430 core
// The character's mesh, translucent so the branches inside stay visible (flat normals from the derivatives).
in vec3 v_world;
uniform vec3 light_direction;
uniform vec4 color;
out vec4 f_color;

void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    float diffuse = abs(dot(n, normalize(light_direction)));
    f_color = vec4(color.rgb * (0.45 + 0.55 * diffuse), color.a);
}
