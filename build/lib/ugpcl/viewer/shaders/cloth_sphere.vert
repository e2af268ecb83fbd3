#version 430 core
// The collider (vol.4 ch.3 sample scene): Unity's built-in Sphere (radius 0.5) scaled by localScale, moved by
// ColliderTranslate. Shaded by cloth.frag.
in vec3 in_position;
in vec3 in_normal;
uniform mat4 m_proj;
uniform mat4 m_view;
uniform vec3 center;
uniform float radius;

out vec3 v_world;
out vec3 v_normal;

void main() {
    v_world = center + in_position * radius;  // in_position is on the unit sphere
    v_normal = in_normal;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
}
