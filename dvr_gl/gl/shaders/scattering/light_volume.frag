#version 330 core
// The light volume (common/scattering.glsl's LIGHT_VOLUME): each light's optical depth at the nodes
// of a grid spanning the volume's box, by a shadow ray marched from every node (shadow_depth: the
// sample distance, the last segment shortened, midpoints sampled), one light per channel.  Full-screen
// passes over targets of nx by ny * (slabs) texels: texel (i, j + ny (k - first)) is node (i, j, k).
// The defines are the frame's classification ones (the extinction as its samples see it) with
// SCATTERING and SHADOWS; dvr_gl.reference.scattering marches the same rays in float64.

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
uniform ivec3 u_nodes;   // light-volume nodes (x, y, z)
uniform int u_first_k;   // this pass's first slab of nodes (a target holds at most GL's texture height)

#include "common/classify.glsl"

layout(location = 0) out vec4 frag_depth;

void main() {
    ivec2 f = ivec2(gl_FragCoord.xy);
    ivec3 node = ivec3(f.x, f.y % u_nodes.y, u_first_k + f.y / u_nodes.y);
    vec3 p = u_box_lo + vec3(node) / vec3(max(u_nodes - 1, ivec3(1))) * (u_box_hi - u_box_lo);
    vec4 depth = vec4(0.0);
    for (int i = 0; i < NUM_SCATTER_LIGHTS; ++i) {
        vec3 toward, energy;
        float reach;
        light_at(i, p, toward, energy, reach);
        depth[i] = shadow_depth(p, toward, reach);
    }
    frag_depth = depth;
}
