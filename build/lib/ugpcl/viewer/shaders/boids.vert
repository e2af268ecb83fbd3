#version 430 core
// BoidsRender.shader (vol.1 ch.3), vertex part: one instanced cube per boid, turned to fly along its velocity.
// Instance matrix = T(position) * Ry(yaw) * Rx(pitch) * S(object_scale): the book's rotation with roll 0 (fig. 3.7).
in vec3 in_position;
in vec3 in_normal;
// per instance: the Boid record of clkernels/include/boid.h
in vec4 in_velocity;
in vec4 in_offset;

uniform mat4 m_proj;
uniform mat4 m_view;
uniform vec3 object_scale;

out vec3 v_world;
out vec3 v_normal;
out float v_speed;

void main() {
    vec3 velocity = in_velocity.xyz;
    float speed = length(velocity);
    float yaw = atan(velocity.x, velocity.z);
    float pitch = -asin(clamp(velocity.y / (speed + 1e-8), -1.0, 1.0));
    mat3 ry = mat3(cos(yaw), 0.0, -sin(yaw), 0.0, 1.0, 0.0, sin(yaw), 0.0, cos(yaw));        // columns
    mat3 rx = mat3(1.0, 0.0, 0.0, 0.0, cos(pitch), sin(pitch), 0.0, -sin(pitch), cos(pitch));
    mat3 rotation = ry * rx;
    v_world = rotation * (in_position * object_scale) + in_offset.xyz;
    v_normal = rotation * (in_normal * object_scale);  // exact for a box: its normals are axis-aligned
    v_speed = speed;
    gl_Position = m_proj * m_view * vec4(v_world, 1.0);
}
