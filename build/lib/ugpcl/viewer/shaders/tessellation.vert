#version 430 core
// Tessellation.shader (vol.4 ch.6), vertex stage: the plane's control points go to the hull stage untouched, in
// object space (the book's InternalTessInterp_appdata: vertex, tangent, normal, texcoord).
in vec3 in_position;
in vec3 in_normal;
in vec4 in_tangent;
in vec2 in_uv;
out vec3 vc_position;
out vec3 vc_normal;
out vec4 vc_tangent;
out vec2 vc_uv;

void main() {
    vc_position = in_position;
    vc_normal = in_normal;
    vc_tangent = in_tangent;
    vc_uv = in_uv;
}
