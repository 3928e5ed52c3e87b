// Single scattering toward the eye with shadows, as dvr_gl.reference.scattering: a sample's colour
// times (1 - albedo) + albedo * sum over the lights of 4 pi p(cos theta) E T, with p the phase
// function normalised to 1 over the sphere, cos theta between the direction the light travels and
// the direction toward the eye, E the light's irradiance (a point light's over its squared distance,
// at least u_min_light_distance) and T the transmittance toward the light.
// SHADOWS: T from a shadow ray marched from the sample in segments of u_shadow_step to where it
// leaves the box (or reaches a point light), the last one shortened, each sampled at its midpoint
// (dvr_gl.reference.discrete's shadow rays); it stops once its optical depth passes
// SHADOW_DEPTH_LIMIT (the light left is below float32's resolution of 1).
// LIGHT_VOLUME: T from the light volume instead, each light's optical depth at the nodes of a grid
// spanning the box (one channel per light; dvr_gl/gl/shaders/scattering/light_volume.frag marches the shadow
// rays from the nodes), interpolated trilinearly with float weights (as dvr_gl.reference.scattering).
// HALF_ANGLE: T from half-angle slicing's light buffer (dvr_gl.half_angle: one directional light; the
// optical depth the slices nearer the light left, bilinear between its pixel centres, clamped).
// Defines: NUM_SCATTER_LIGHTS, PHASE_HG (Henyey-Greenstein; else isotropic), SHADOWS, LIGHT_VOLUME,
// HALF_ANGLE; ALBEDO_TABLE: the caller passes the transfer function's albedo at the sample (else
// u_albedo).  Needs: u_box_lo, u_box_hi, and float extinction(vec3 p) (classify.glsl).

#include "common/box.glsl"

uniform vec4 u_scatter_light[NUM_SCATTER_LIGHTS];       // w 0: xyz the unit vector toward a directional
                                                        // light; w 1: a point light's position
uniform vec3 u_scatter_irradiance[NUM_SCATTER_LIGHTS];  // intensity * colour
uniform float u_albedo;
uniform float u_min_light_distance;                     // world units
#ifdef PHASE_HG
uniform float u_phase_g;
#endif
#ifdef SHADOWS
uniform float u_shadow_step;                            // world units
const float SHADOW_DEPTH_LIMIT = 20.0;
#endif
#ifdef HALF_ANGLE
uniform sampler2D u_light_buffer;                       // R32F: optical depth toward the light
uniform vec3 u_light_origin;                            // the buffer's corner (world)
uniform vec3 u_light_u;                                 // its axes over their extents: uv = (p - origin) . u, v
uniform vec3 u_light_v;
uniform ivec2 u_light_buffer_size;

float light_buffer_depth(vec3 p) {
    vec2 uv = vec2(dot(p - u_light_origin, u_light_u), dot(p - u_light_origin, u_light_v));
    vec2 n = vec2(u_light_buffer_size);
    vec2 x = clamp(uv * n - 0.5, vec2(0.0), n - 1.0);
    ivec2 i0 = min(ivec2(floor(x)), u_light_buffer_size - 2);
    vec2 f = x - vec2(i0);
    float a = texelFetch(u_light_buffer, i0, 0).r;
    float b = texelFetch(u_light_buffer, i0 + ivec2(1, 0), 0).r;
    float c = texelFetch(u_light_buffer, i0 + ivec2(0, 1), 0).r;
    float d = texelFetch(u_light_buffer, i0 + ivec2(1, 1), 0).r;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}
#endif
#ifdef LIGHT_VOLUME
uniform sampler3D u_light_volume;                       // 32-bit float, nearest: light i's optical depth in channel i
uniform ivec3 u_light_volume_dims;                      // nodes (x, y, z)

// The optical depths toward the lights at p: trilinear between the nodes, clamped to the box.
vec4 light_volume_depths(vec3 p) {
    vec3 n = vec3(u_light_volume_dims - 1);
    vec3 u = clamp((p - u_box_lo) / max(u_box_hi - u_box_lo, vec3(1e-30)) * n, vec3(0.0), n);
    ivec3 i0 = min(ivec3(floor(u)), max(u_light_volume_dims - 2, ivec3(0)));
    vec3 f = u - vec3(i0);
    ivec3 top = u_light_volume_dims - 1;
    vec4 out_depth = vec4(0.0);
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                ivec3 c = min(i0 + ivec3(dx, dy, dz), top);
                float w = (dx == 1 ? f.x : 1.0 - f.x) * (dy == 1 ? f.y : 1.0 - f.y) * (dz == 1 ? f.z : 1.0 - f.z);
                out_depth += w * texelFetch(u_light_volume, c, 0);
            }
    return out_depth;
}
#endif

// 4 pi p(cos theta): 1 for the isotropic phase; Henyey-Greenstein with its denominator as a sum of
// non-negative terms (dvr_gl.reference.scattering.henyey_greenstein).
float scatter_phase(float mu) {
#ifdef PHASE_HG
    float g = u_phase_g;
    float denom = g >= 0.0 ? (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - mu)
                           : (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + mu);
    return (1.0 - g) * (1.0 + g) / (denom * sqrt(denom));
#else
    return 1.0;
#endif
}

#ifdef SHADOWS
// Optical depth from p along unit vector `toward` over [0, reach].
float shadow_depth(vec3 p, vec3 toward, float reach) {
    int n = int(ceil(reach / u_shadow_step));
    float tau = 0.0;
    for (int k = 0; k < n && tau < SHADOW_DEPTH_LIMIT; ++k) {
        float a = float(k) * u_shadow_step;
        float b = min(a + u_shadow_step, reach);
        tau += extinction(p + 0.5 * (a + b) * toward) * (b - a);
    }
    return tau;
}
#endif

// Light i seen from p: the unit vector toward it, its irradiance there, and how far a shadow ray
// goes (to the box's exit, or to a point light inside it).
void light_at(int i, vec3 p, out vec3 toward, out vec3 energy, out float reach) {
    vec4 light = u_scatter_light[i];
    toward = light.xyz;
    energy = u_scatter_irradiance[i];
    float distance = 3.0e38;
    if (light.w > 0.5) {
        vec3 v = light.xyz - p;
        distance = length(v);
        toward = distance > 0.0 ? v / distance : vec3(0.0, 0.0, 1.0);
        float r = max(distance, u_min_light_distance);
        energy /= r * r;
    }
    float enter, leave;
    intersect_box(p, toward, u_box_lo, u_box_hi, enter, leave);
    reach = clamp(min(leave, distance), 0.0, 3.0e38);
}

// (1 - albedo) + albedo F at p, seen along the unit ray direction dir.
vec3 scattering_factor(vec3 p, vec3 dir, float albedo) {
    vec3 total = vec3(0.0);
#ifdef LIGHT_VOLUME
    vec4 depths = light_volume_depths(p);
#endif
    for (int i = 0; i < NUM_SCATTER_LIGHTS; ++i) {
        vec3 toward, energy;
        float reach;
        light_at(i, p, toward, energy, reach);
        vec3 lit = scatter_phase(dot(toward, dir)) * energy;  // cos theta = (-toward) . (-dir)
#if defined(LIGHT_VOLUME)
        lit *= exp(-depths[i]);
#elif defined(HALF_ANGLE)
        lit *= exp(-light_buffer_depth(p));  // one light
#elif defined(SHADOWS)
        lit *= exp(-shadow_depth(p, toward, reach));
#endif
        total += lit;
    }
    return (1.0 - albedo) + albedo * total;
}
