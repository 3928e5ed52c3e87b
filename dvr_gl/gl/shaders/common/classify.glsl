// Classification shared by the renderers that sample a grid in their shaders: what a sample (or a pre-integrated
// slab) emits and absorbs, shaded, with gradient-magnitude opacity, as dvr_gl.reference.model; TRANSFER_FUNCTION_2D:
// classified by value and gradient magnitude (common/transfer_function_2d.glsl).
// Needs: u_gradient_reference, and u_slab_length: the pre-integration table's segment length.

#ifdef CLASSIFY_PRE
uniform sampler3D u_classified;      // (sigma c, sigma), or (c, sigma) without ASSOCIATED_COLORS
#endif
#ifdef CLASSIFY_PREINTEGRATED
#include "common/preintegration.glsl"
#endif
#ifdef TRANSFER_FUNCTION_2D  // by value and gradient magnitude (post-classification alone; needs gradient())
#include "common/transfer_function_2d.glsl"
#endif

#ifdef SCATTERING
// Extinction at p alone (what attenuates a shadow ray), as classify() finds it.
float extinction(vec3 p) {
#ifdef CLASSIFY_PRE
    float sigma = max(sample_texture(u_classified, voxel_coord(p)).a, 0.0);
#else
    float sigma = transfer_function(sample_scalar(p)).a;
#endif
#ifdef GRADIENT_OPACITY
    sigma *= min(1.0, length(gradient(p)) / u_gradient_reference);
#endif
    return sigma;
}
#include "common/scattering.glsl"
#endif

// Shaded (or lit by scattering) non-associated colour and extinction at p.
vec4 classify(vec3 p, vec3 dir) {
#ifdef CLASSIFY_PRE
    vec4 c = max(sample_texture(u_classified, voxel_coord(p)), 0.0);  // cubics may overshoot
  #ifdef ASSOCIATED_COLORS
    vec3 colour = c.a > 0.0 ? c.rgb / c.a : vec3(0.0);
  #else
    vec3 colour = c.rgb;
  #endif
    float sigma = c.a;
#else
    float value = sample_scalar(p);
  #ifdef TRANSFER_FUNCTION_2D
    vec3 g = gradient(p);  // what shading and gradient opacity read too
    vec4 tf = transfer_function_2d(value, length(g));
  #else
    vec4 tf = transfer_function(value);
  #endif
    vec3 colour = tf.rgb;
    float sigma = tf.a;
#endif
#if defined(NEEDS_GRADIENT) && !defined(TRANSFER_FUNCTION_2D)
    vec3 g = gradient(p);
#endif
#ifdef GRADIENT_OPACITY
    sigma *= min(1.0, length(g) / u_gradient_reference);
#endif
#ifdef SHADING
    colour = blinn_phong(colour, g, dir);
#endif
#if defined(SCATTERING) && defined(ALBEDO_TABLE)  // never with CLASSIFY_PRE (dvr_gl.scene.settings.check_albedo)
    colour *= scattering_factor(p, dir, albedo_table(value));
#elif defined(SCATTERING)
    colour *= scattering_factor(p, dir, u_albedo);
#endif
    return vec4(colour, sigma);
}

#ifdef CLASSIFY_PREINTEGRATED
// (associated colour, optical depth) of a segment of length len from the table by its end values;
// gradient opacity and shading at its midpoint p, as dvr_gl.reference.model does.
vec4 preintegrated_segment(float front, float back, float len, vec3 p, vec3 dir) {
    vec4 e = shorten(preintegrated(front, back), len / u_slab_length);
  #ifdef NEEDS_GRADIENT
    vec3 g = gradient(p);
  #endif
  #ifdef GRADIENT_OPACITY
    e = shorten(e, min(1.0, length(g) / u_gradient_reference));
  #endif
  #ifdef SHADING
    float alpha = opacity_of_depth(e.a);
    e.rgb = blinn_phong(alpha > 0.0 ? e.rgb / alpha : vec3(0.0), g, dir) * alpha;
  #endif
  #if defined(SCATTERING) && defined(ALBEDO_TABLE)
    e.rgb *= scattering_factor(p, dir, albedo_table(sample_scalar(p)));  // lit as its middle is
  #elif defined(SCATTERING)
    e.rgb *= scattering_factor(p, dir, u_albedo);  // the segment lit as its middle is
  #endif
    return e;
}
#endif

