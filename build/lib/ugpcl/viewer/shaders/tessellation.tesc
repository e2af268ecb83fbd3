#version 430 core
// Tessellation.shader (vol.4 ch.6), hull stage: hull_shader copies the 3 control points; hull_const sets the
// factors with Unity's UnityEdgeLengthBasedTessCull(v0, v1, v2, _EdgeLength, _Displacement * 1.5):
//   edge factor F(a, b) = max(|a - b| * _ScreenParams.y / (_EdgeLength * |(a + b)/2 - camera|), 1), world space;
//   outer[i] = F of the edge opposite corner i (SV_TessFactor[i] = gl_TessLevelOuter[i]), inner = their mean;
//   every factor 0 (patch discarded) when the triangle lies more than the slack outside one side plane of the
//   frustum. F(a, b) = F(b, a) exactly (a + b and |a - b| are symmetric in IEEE arithmetic), so the two patches
//   sharing an edge agree on its factor and the tessellated surface has no cracks.
layout(vertices = 3) out;

in vec3 vc_position[];
in vec3 vc_normal[];
in vec4 vc_tangent[];
in vec2 vc_uv[];
out vec3 tc_position[];
out vec3 tc_normal[];
out vec4 tc_tangent[];
out vec2 tc_uv[];

uniform mat4 m_model;         // unity_ObjectToWorld
uniform mat4 tess_view_proj;  // the camera the factors are computed for (the drawing camera unless frozen)
uniform vec3 tess_eye;        // _WorldSpaceCameraPos of that camera
uniform float screen_height;  // _ScreenParams.y: render target height in pixels
uniform float edge_length;    // _EdgeLength, pixels
uniform float displacement;   // _Displacement: the cull slack is 1.5 times it
uniform float forced_level;   // tests and debugging: >= 0 sets every level to it; < 0 = the formula

#ifdef CAPTURE
layout(std430, binding = 0) buffer Factors { vec4 captured_factors[]; };  // per patch: outer[0..2], inner
uniform int first_patch;  // gl_PrimitiveID restarts at 0 in every draw call: the view draws the plane in batches
#endif

float edge_factor(vec3 a, vec3 b) {  // UnityCalcEdgeTessFactor
    float dist = distance(0.5 * (a + b), tess_eye);
    float len = distance(a, b);
    return max(len * screen_height / (edge_length * dist), 1.0);
}

vec4 matrix_row(mat4 m, int i) { return vec4(m[0][i], m[1][i], m[2][i], m[3][i]); }  // GLSL matrices are column-major

bool frustum_culled(vec3 p0, vec3 p1, vec3 p2, float slack) {  // UnityWorldViewFrustumCull
    vec4 x = matrix_row(tess_view_proj, 0), y = matrix_row(tess_view_proj, 1), w = matrix_row(tess_view_proj, 3);
    vec4 planes[4] = vec4[4](w + x, w - x, w + y, w - y);  // left, right, bottom, top: inside where >= 0
    for (int k = 0; k < 4; k++) {
        vec4 plane = planes[k] / length(planes[k].xyz);  // distances in world units
        if (dot(plane.xyz, p0) + plane.w < -slack && dot(plane.xyz, p1) + plane.w < -slack &&
            dot(plane.xyz, p2) + plane.w < -slack)
            return true;  // all three corners beyond one side plane
    }
    return false;
}

void main() {
    tc_position[gl_InvocationID] = vc_position[gl_InvocationID];
    tc_normal[gl_InvocationID] = vc_normal[gl_InvocationID];
    tc_tangent[gl_InvocationID] = vc_tangent[gl_InvocationID];
    tc_uv[gl_InvocationID] = vc_uv[gl_InvocationID];
    if (gl_InvocationID != 0) return;  // the patch-constant function runs once per patch

    vec3 p0 = (m_model * vec4(vc_position[0], 1.0)).xyz;
    vec3 p1 = (m_model * vec4(vc_position[1], 1.0)).xyz;
    vec3 p2 = (m_model * vec4(vc_position[2], 1.0)).xyz;
    vec4 f;
    if (forced_level >= 0.0) {
        f = vec4(forced_level);
    } else if (frustum_culled(p0, p1, p2, displacement * 1.5)) {
        f = vec4(0.0);
    } else {
        f.x = edge_factor(p1, p2);
        f.y = edge_factor(p2, p0);
        f.z = edge_factor(p0, p1);
        f.w = (f.x + f.y + f.z) / 3.0;
    }
    gl_TessLevelOuter[0] = f.x;
    gl_TessLevelOuter[1] = f.y;
    gl_TessLevelOuter[2] = f.z;
    gl_TessLevelInner[0] = f.w;
#ifdef CAPTURE
    captured_factors[first_patch + gl_PrimitiveID] = f;
#endif
}
