#version 430 core
// One splat's share of this pixel.  Blended by the renderer:
// * SLABS (a sheet buffer) and the average: added up (the kernel's integral times the value, and
//   the core splats' weight, or times the voxel's (sigma c, sigma) when pre-classified);
// * SPLAT_OVER (sheet_buffer = none): the splat composited alone, back to front by the over
//   operator: opacity 1 - exp(-sigma integral), the voxel's colour.
#include "common/camera_ray.glsl"
#include "common/optics.glsl"
#include "splatting/kernel.glsl"

uniform vec3 u_spacing;
uniform float u_radius;

flat in vec4 v_splat;
#ifdef CLASSIFY_PRE
flat in vec4 v_optics;
#endif
flat in float v_core;
out vec4 frag;

void main() {
    vec3 o, d;
    camera_ray(o, d);
    float lo, hi;
    if (!ray_extent(o, d, lo, hi))
        discard;
    float closest2;
    float integral = kernel_integral(o, d, v_splat.xyz, u_spacing, u_radius, lo, hi, closest2);
    if (integral <= 0.0)
        discard;
#if defined(SPLAT_OVER)
    float alpha = opacity_of_depth(v_optics.a * integral);
    vec3 colour = v_optics.a > 0.0 ? v_optics.rgb / v_optics.a : vec3(0.0);
    frag = vec4(colour * alpha, alpha);
#elif defined(CLASSIFY_PRE)
    frag = v_optics * integral;
#else
    // .g: counts the core samples that some point of this slab part is nearest to (within half a
    // voxel's diagonal): a part with none is transparent (culling, dvr_gl/renderers/splatting/splats.py)
    frag = vec4(v_splat.w * integral, closest2 <= 0.75 ? v_core : 0.0, 0.0, 0.0);
#endif
}
