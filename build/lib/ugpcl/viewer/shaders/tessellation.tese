#version 430 core
// Tessellation.shader (vol.4 ch.6), domain stage (domain_shader + disp + vert_process): interpolate the patch's
// attributes with the barycentric SV_DomainLocation (gl_TessCoord.x weights corner 0), move the vertex along the
// normal by the displacement map (tex2Dlod(_DispTex, uv).r * _Displacement; the surface shader adds, the
// vertex/fragment version subtracts: `negative`), then the usual transform. The book's "tri" domain with
// "fractional_odd" partitioning; its triangle_cw winding is irrelevant here (the view draws both faces).
layout(triangles, fractional_odd_spacing, ccw) in;

in vec3 tc_position[];
in vec3 tc_normal[];
in vec4 tc_tangent[];
in vec2 tc_uv[];
out vec3 v_world;    // displaced position, world space
out vec3 v_normal;   // the interpolated, undisplaced normal, world space (Unity never updates it after disp)
out vec4 v_tangent;  // interpolated tangent (world xyz, binormal sign w) for the normal map
out vec2 v_uv;
out float v_level;   // inner tessellation level of the patch (debug colouring)

uniform mat4 m_proj;
uniform mat4 m_view;
uniform mat4 m_model;
uniform sampler2D displacement_map;  // _DispTex: the fluid's density, one texel per cell
uniform float displacement;          // _Displacement
uniform bool negative;               // subtract instead of add

#ifdef CAPTURE
layout(std430, binding = 1) buffer Points {
    uint captured;   // vertices written so far (atomic counter)
    uint capacity;   // room in points[] / 2
    uint pad0, pad1;
    vec4 points[];   // per vertex: (gl_TessCoord, patch index), (world position, d)
};
uniform int first_patch;  // gl_PrimitiveID restarts at 0 in every draw call: the view draws the plane in batches
#endif

void main() {
    vec3 b = gl_TessCoord;
    vec3 position = tc_position[0] * b.x + tc_position[1] * b.y + tc_position[2] * b.z;
    vec3 normal = tc_normal[0] * b.x + tc_normal[1] * b.y + tc_normal[2] * b.z;
    vec4 tangent = tc_tangent[0] * b.x + tc_tangent[1] * b.y + tc_tangent[2] * b.z;
    vec2 uv = tc_uv[0] * b.x + tc_uv[1] * b.y + tc_uv[2] * b.z;
    float d = textureLod(displacement_map, uv, 0.0).r * displacement;  // no derivatives here: level 0
    position += (negative ? -d : d) * normal;                           // disp()
    vec4 world = m_model * vec4(position, 1.0);
    gl_Position = m_proj * m_view * world;
    v_world = world.xyz;
    v_normal = mat3(m_model) * normal;  // rotation and unit scale: no inverse transpose needed
    v_tangent = vec4(mat3(m_model) * tangent.xyz, tangent.w);
    v_uv = uv;
    v_level = gl_TessLevelInner[0];
#ifdef CAPTURE
    uint k = atomicAdd(captured, 1u);  // old value = this vertex's slot
    if (k < capacity) {
        points[2u * k] = vec4(b, float(first_patch + gl_PrimitiveID));
        points[2u * k + 1u] = vec4(world.xyz, d);
    }
#endif
}
