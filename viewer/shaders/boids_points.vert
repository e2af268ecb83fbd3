#version 430 core
// Boids far away (View.POINT_BOIDS): one point per boid instead of an instanced cube. A million boids are a pixel or
// two each on screen, and the lent H100/H200 run vertex work on two of their TPCs: 36 cube vertices a boid held a
// million-boid frame at 61 ms there. The point is as wide as the boid's mean side (at least a pixel) and lit as the
// long side of its cube that faces the eye (the eye's direction less its part along the velocity), so boids flying
// different ways shade differently as the cubes do; boids.frag shades it.
in vec4 in_velocity;
in vec4 in_offset;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform vec3 eye;
uniform vec3 object_scale;
uniform float pixels_per_unit;  // a unit at distance 1 on screen: m_proj[1][1] * viewport height / 2

out vec3 v_world;
out vec3 v_normal;
out float v_speed;

void main() {
    v_world = in_offset.xyz;
    v_speed = length(in_velocity.xyz);
    vec3 to_eye = normalize(eye - v_world);
    vec3 along = in_velocity.xyz / max(v_speed, 1e-8);
    vec3 side = to_eye - dot(to_eye, along) * along;
    v_normal = dot(side, side) > 1e-8 ? normalize(side) : to_eye;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
    float mean_side = (object_scale.x + object_scale.y + object_scale.z) / 3.0;
    gl_PointSize = clamp(mean_side * pixels_per_unit / max(gl_Position.w, 1e-6), 1.0, 16.0);
}
