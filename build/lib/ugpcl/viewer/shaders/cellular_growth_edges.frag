#version 430 core
// CellularGrowth's edge shader, fragment part: white lines, blended additively.
in float v_alpha;
out vec4 f_color;

void main() {
    f_color = vec4(1.0, 1.0, 1.0, v_alpha);
}
