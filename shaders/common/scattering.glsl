// Single scattering toward the eye with shadows, as dvr_gl.reference.scattering: a sample's colour
// times (1 - albedo) + albedo * sum over the lights of 4 pi p(cos theta) E T, with p the phase
// function normalised to 1 over the sphere, cos theta between the direction the light travels and
// the direction toward the eye, E the light's irradiance (a point light's over its squared distance,
// at least u_min_light_distance) and T the transmittance toward the light.
// SHADOWS: T from a shadow ray marched from the sample in segments of u_shadow_step to where it
// leaves the box (or reaches a point light), the last one shortened, each sampled at its midpoint
// (dvr_gl.reference.discrete's shadow rays); it stops once its optical depth passes
// SHADOW_DEPTH_LIMIT (the light left is below float32's resolution of 1).
// Defines: NUM_SCATTER_LIGHTS, PHASE_HG (Henyey-Greenstein; else isotropic), SHADOWS.
// Needs: u_box_lo, u_box_hi, and float extinction(vec3 p) (classify.glsl).

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

// (1 - albedo) + albedo F at p, seen along the unit ray direction dir.
vec3 scattering_factor(vec3 p, vec3 dir) {
    vec3 total = vec3(0.0);
    for (int i = 0; i < NUM_SCATTER_LIGHTS; ++i) {
        vec4 light = u_scatter_light[i];
        vec3 toward = light.xyz;
        vec3 energy = u_scatter_irradiance[i];
        float distance = 3.0e38;
        if (light.w > 0.5) {
            vec3 v = light.xyz - p;
            distance = length(v);
            toward = distance > 0.0 ? v / distance : vec3(0.0, 0.0, 1.0);
            float r = max(distance, u_min_light_distance);
            energy /= r * r;
        }
        vec3 lit = scatter_phase(dot(toward, dir)) * energy;  // cos theta = (-toward) . (-dir)
#ifdef SHADOWS
        float enter, leave;
        intersect_box(p, toward, u_box_lo, u_box_hi, enter, leave);
        float reach = clamp(min(leave, distance), 0.0, 3.0e38);
        lit *= exp(-shadow_depth(p, toward, reach));
#endif
        total += lit;
    }
    return (1.0 - u_albedo) + u_albedo * total;
}
