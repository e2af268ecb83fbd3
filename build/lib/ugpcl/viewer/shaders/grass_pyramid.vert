#version 430 core
// SimpleGeometryShader (vol.1 ch.6), vertex part vert(): the object-space vertex goes straight to the geometry shader.
in vec3 in_position;

out vec3 v_position;

void main() {
    v_position = in_position;
}
