#version 430 core
// The SkinnedAnimation scene's floor (a Unity Plane, 20 x 20 at y = 0): world position and light-space position.
in vec3 in_position;
uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_light;  // light projection * light view: where the shadow map stored this point's depth

out vec3 v_world;
out vec4 v_light;

void main() {
    v_world = in_position;
    v_light = m_light * vec4(in_position, 1.0);
    gl_Position = m_proj * m_view * vec4(in_position, 1.0);
}
