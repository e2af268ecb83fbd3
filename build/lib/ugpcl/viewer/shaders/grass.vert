#version 430 core
// Grass.shader (vol.1 ch.6), vertex part vert(): pass the object-space vertex on and read the three noise maps at
// its UV with an explicit LOD 0 (tex2Dlod; only .r is used). The plane's model matrix (PlaneDeployer, one per
// instance) rides along to the geometry shader, which builds the blade in object space.
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
// per instance
in mat4 in_model;

uniform sampler2D height_map;
uniform sampler2D rotation_map;
uniform sampler2D wind_map;

out vec3 v_position;
out vec3 v_normal;
out float v_height;
out float v_rot;
out float v_wind;
flat out mat4 v_model;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_height = textureLod(height_map, in_uv, 0.0).r;
    v_rot = textureLod(rotation_map, in_uv, 0.0).r;
    v_wind = textureLod(wind_map, in_uv, 0.0).r;
    v_model = in_model;
}
