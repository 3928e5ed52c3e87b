#version 330 core
// Half-angle slicing's light pass (dvr_gl.half_angle): one slice drawn into the light buffer, seen
// orthographically along the light, adding its optical depth sigma * u_light_length (the spacing over
// |l . h|) with additive blending.  The defines are the eye pass's classification ones with
// SCATTERING (for extinction()); slice.vert places the polygon.

#ifdef GRADIENT_OPACITY
#define NEEDS_GRADIENT
#endif

#include "common/volume_sample.glsl"
#include "common/gradient.glsl"
#include "common/transfer_function.glsl"
#include "common/optics.glsl"
#include "common/shading.glsl"

uniform vec3 u_box_lo;
uniform vec3 u_box_hi;
uniform float u_gradient_reference;
uniform float u_light_length;

#include "common/classify.glsl"

in vec3 world;
out vec4 frag_depth;

void main() {
    // the polygon is drawn in a grown box: the volume's own box decides, by the fragment's position
    if (any(lessThan(world, u_box_lo)) || any(greaterThan(world, u_box_hi))) discard;
    frag_depth = vec4(extinction(world) * u_light_length, 0.0, 0.0, 0.0);
}
