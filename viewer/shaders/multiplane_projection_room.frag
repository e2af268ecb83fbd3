#version 430 core
// The room's faces show their face images unlit (projector light), on the room side only: Unity's Quad is
// one-sided, so an outside camera sees into the room through the walls' backs.
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;

uniform sampler2D face_image;
uniform vec3 eye;

out vec4 f_color;

void main() {
    if (dot(eye - v_position, v_normal) <= 0.0) discard;
    f_color = vec4(texture(face_image, v_uv).rgb, 1.0);
}
