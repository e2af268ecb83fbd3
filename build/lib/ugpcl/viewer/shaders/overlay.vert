#version 430 core
// Text overlay panel (no book shader): a unit quad placed by `rect` = (x, y, w, h) in clip space.
in vec2 in_corner;
uniform vec4 rect;
out vec2 v_uv;

void main() {
    v_uv = in_corner;
    gl_Position = vec4(rect.xy + in_corner * rect.zw, 0.0, 1.0);
}
