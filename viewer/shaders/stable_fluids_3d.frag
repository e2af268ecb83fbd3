#version 430 core
// Stable fluids 3D (vol.1 ch.4; no book shader: Solver3D has no renderer). The shown field of the solver volume
// (density, or the speed |(u, v, w)|, one half float a cell: Simulation.draw_volume) is drawn inside a box centred
// on the origin, either ray-marched front to back (alpha = 1 - exp(-k * value * step), white smoke lit by one shadow
// ray towards the light) or as one axis-aligned slice.
in vec2 v_ndc;
out vec4 f_color;

uniform sampler3D volume;        // R16F, linear filter: density or speed; texel centres at (i + 0.5) / n
                                 // (speed: |v| per cell, filtered; where the velocity turns within a cell a
                                 // little above the length of the filtered velocity)
uniform mat4 m_inv_view_proj;    // clip -> scene coordinates
uniform vec3 eye;                // camera position, scene coordinates
uniform vec3 box_size;           // world size of the grid (largest edge 1)
uniform float step_size;         // ray step, world units (half a cell)
uniform int display;             // 0: ray-marched volume, 1: slice
uniform int field;               // 0: density, 1: speed |(u, v, w)|
uniform float absorption;        // extinction per unit value per box length
uniform float value_scale;       // density: 1; speed: 1 / max speed (so the fastest cell reads 1)
uniform float slice_scale;       // slice colour = value * slice_scale (host: 1 / the field's max)
uniform int slice_axis;          // 0 x, 1 y, 2 z
uniform float slice_position;    // slice coordinate in [0, 1] along slice_axis
uniform vec3 light_dir;          // towards the light, scene coordinates (normalised)

const int MAX_STEPS = 1024;
const int SHADOW_STEPS = 8;
const vec3 SMOKE = vec3(0.95);
const float AMBIENT = 0.55;

float value_at(vec3 uvw) { return texture(volume, uvw).r * value_scale; }

vec3 heat(float t) {  // black-body-like ramp for speeds: blue -> red -> yellow -> white
    t = clamp(t, 0.0, 1.0);
    return clamp(vec3(3.0 * t - 0.6, 3.0 * t - 1.6, 0.6 - 1.5 * abs(t - 0.25) + 2.0 * max(t - 0.75, 0.0)), 0.0, 1.0);
}

// Entry and exit distances of the ray (origin o, direction d) through the box; t_far <= t_near: a miss.
vec2 box_hit(vec3 o, vec3 d) {
    vec3 inv = 1.0 / mix(d, vec3(1e-8), lessThan(abs(d), vec3(1e-8)));  // no division by an exact 0
    vec3 t0 = (-0.5 * box_size - o) * inv, t1 = (0.5 * box_size - o) * inv;
    vec3 lo = min(t0, t1), hi = max(t0, t1);
    return vec2(max(max(lo.x, lo.y), max(lo.z, 0.0)), min(min(hi.x, hi.y), hi.z));
}

vec3 to_uvw(vec3 p) { return p / box_size + 0.5; }

void main() {
    vec4 near = m_inv_view_proj * vec4(v_ndc, -1.0, 1.0);
    vec4 far = m_inv_view_proj * vec4(v_ndc, 1.0, 1.0);
    vec3 dir = normalize(far.xyz / far.w - near.xyz / near.w);
    vec2 hit = box_hit(eye, dir);
    if (hit.y <= hit.x) discard;
    float box_length = max(box_size.x, max(box_size.y, box_size.z));

    if (display == 1) {  // one opaque slice through the box
        float t = (slice_position - 0.5) * box_size[slice_axis] - eye[slice_axis];
        if (abs(dir[slice_axis]) < 1e-8) discard;
        t /= dir[slice_axis];
        if (t < hit.x - 1e-5 || t > hit.y + 1e-5) discard;
        float value = value_at(to_uvw(eye + t * dir)) * slice_scale;
        f_color = vec4(field == 0 ? vec3(clamp(value, 0.0, 1.0)) : heat(value), 1.0);
        return;
    }

    float k = absorption / box_length;  // extinction per unit value per world unit
    vec3 color = vec3(0.0);
    float transmittance = 1.0;
    int steps = min(int(ceil((hit.y - hit.x) / step_size)), MAX_STEPS);
    for (int i = 0; i < steps; i++) {
        vec3 p = eye + (hit.x + (float(i) + 0.5) * step_size) * dir;
        float value = value_at(to_uvw(p));
        if (value <= 1e-5) continue;  // empty space: nothing to absorb or light
        float alpha = 1.0 - exp(-k * value * step_size);
        vec3 albedo = SMOKE;
        float light = 1.0;
        if (field == 0) {  // one shadow ray: how much smoke lies between p and the light
            float depth = 0.0;
            float shadow_step = 0.5 * box_length / float(SHADOW_STEPS);
            for (int j = 1; j <= SHADOW_STEPS; j++) {
                vec3 q = p + float(j) * shadow_step * light_dir;
                if (any(greaterThan(abs(q), 0.5 * box_size))) break;
                depth += value_at(to_uvw(q)) * shadow_step;
            }
            light = AMBIENT + (1.0 - AMBIENT) * exp(-k * depth);
        } else {
            albedo = heat(value);
        }
        color += transmittance * alpha * albedo * light;
        transmittance *= 1.0 - alpha;
        if (transmittance < 0.01) break;  // opaque enough: what lies behind cannot show
    }
    f_color = vec4(color, 1.0 - transmittance);  // premultiplied: blend ONE, ONE_MINUS_SRC_ALPHA
}
