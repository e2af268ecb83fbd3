#version 430 core
// CircleGeometry.shader (vol.4 ch.7), vertex part, geometry-shader path: the sample's point passes through.
in vec2 in_center;
in vec4 in_color;

out vec2 v_center;
out vec4 v_color;

void main() {
    v_center = in_center;
    v_color = in_color;
}
