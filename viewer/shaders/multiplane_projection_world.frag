#version 430 core
// The shading of clkernels/multiplane_projection.cl (trace, sky): sun + ambient, a soft checker on the ground,
// fog towards the sky with distance from the eye. The values come from the host's World record.
const int SHADE_SKY = 0, SHADE_SHAPE = 1, SHADE_GROUND = 2;

in vec3 v_world;
in vec3 v_normal;
in vec3 v_color;

uniform vec3 eye;  // the face cameras' position in the CG world
uniform int shading;
uniform vec3 sun_direction;
uniform vec3 sun_color;
uniform vec3 ambient;
uniform vec3 sky_horizon;
uniform vec3 sky_zenith;
uniform vec3 ground_dark;
uniform vec3 ground_light;
uniform vec3 ground;  // height, checker square size, fog distance

out vec4 f_color;

vec3 sky(vec3 dir) {
    return mix(sky_horizon, sky_zenith, sqrt(clamp(dir.y, 0.0, 1.0)));
}

void main() {
    vec3 to_point = v_world - eye;
    float t = length(to_point);
    vec3 dir = to_point / t;
    if (shading == SHADE_SKY) {
        f_color = vec4(sky(dir), 1.0);
        return;
    }
    vec3 albedo = v_color;
    if (shading == SHADE_GROUND) {
        float k = 3.14159265 / ground.y;
        albedo = mix(ground_dark, ground_light, 0.5 + 0.5 * sin(k * v_world.x) * sin(k * v_world.z));
    }
    float diffuse = max(dot(normalize(v_normal), -sun_direction), 0.0);
    vec3 lit = albedo * (ambient + sun_color * diffuse);
    f_color = vec4(mix(lit, sky(dir), 1.0 - exp(-t / ground.z)), 1.0);
}
