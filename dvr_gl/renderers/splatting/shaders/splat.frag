#version 430 core
// One splat's share of this pixel.  Blended by the renderer:
// * SLABS (a sheet buffer) and the average: added up (the kernel's integral times the value, and
//   the core splats' weight, or times the voxel's (sigma c, sigma) when pre-classified);
// * SPLAT_OVER (sheet_buffer = none): the splat composited alone, back to front by the over
//   operator: opacity 1 - exp(-sigma integral), the voxel's colour.
#include "common/camera_ray.glsl"
#include "common/optics.glsl"
#include "kernel.glsl"
#ifdef KERNEL_BSPLINE
#include "bspline.glsl"
#endif
#ifdef PARTICLES
#include "m4.glsl"
flat in vec4 v_particle;  // h, weight m / rho, sub-pixel (splat.vert)
#endif

uniform vec3 u_spacing;
uniform float u_radius;

flat in vec4 v_splat;
#ifdef CLASSIFY_PRE
flat in vec4 v_optics;
#endif
flat in float v_core;
#ifdef SLAB_GROUP
// several slabs at once (renderer.py): the group's slab boundaries (view depths) and a sheet each
uniform float u_group[SLAB_GROUP + 1];
out vec4 frags[SLAB_GROUP];
#else
out vec4 frag;
#endif

#ifdef ERT
uniform sampler2D u_accumulated;  // the sheets composited so far (front to back)
uniform float u_ert;
#endif

// This splat's share of the ray (o, d) over its part [lo, hi] (slab: the part's slab's view depths, for
// a particle smaller than a pixel, whose share of a slab is its mass between the slab's planes).
vec4 contribution(vec3 o, vec3 d, float lo, float hi, vec2 slab, bool subpixel) {
    float closest2 = 0.0;
#ifdef PARTICLES
    float integral;
    if (subpixel) {
        vec3 p = v_splat.xyz - u_eye;
        float z = dot(p, u_forward);
        vec2 ndc_per_world = 1.0 / u_half_extent;
#ifndef CAMERA_ORTHOGRAPHIC
        ndc_per_world /= z;
#endif
        // per unit of the ray's length: the pixel's mean column along the view axis over the cosine of
        // the angle of the ray through the particle to it (1 in orthographic views)
        integral = m4_pixel_average(v_splat.xyz, v_particle.x, ndc_per_world) / length(d);
#ifndef CAMERA_ORTHOGRAPHIC
        integral *= length(p) / z;
#endif
#ifdef SLABS
        integral *= m4_slab_share(z, v_particle.x, slab.x, slab.y);
#endif
    } else {
        integral = m4_integral(o, d, v_splat.xyz, v_particle.x, lo, hi);
    }
    integral *= v_particle.y;  // m / rho
#elif defined(KERNEL_BSPLINE)
    float integral = bspline_integral(o, d, v_splat.xyz, u_spacing, lo, hi);
    {   // the part's nearest point to the sample, voxels (culling's core test, below)
        vec3 uo = (o + lo * d - v_splat.xyz) / u_spacing, ud = d / u_spacing;
        vec3 closest = uo + clamp(-dot(uo, ud) / dot(ud, ud), 0.0, hi - lo) * ud;
        closest2 = dot(closest, closest);
    }
#else
    float integral = kernel_integral(o, d, v_splat.xyz, u_spacing, u_radius, lo, hi, closest2);
#endif
    if (integral <= 0.0)
        return vec4(0.0);
#if defined(SPLAT_OVER)
    float alpha = opacity_of_depth(v_optics.a * integral);
    vec3 colour = v_optics.a > 0.0 ? v_optics.rgb / v_optics.a : vec3(0.0);
    return vec4(colour * alpha, alpha);
#elif defined(CLASSIFY_PRE)
    return v_optics * integral;
#else
    // .g: counts the core samples that some point of this slab part is nearest to (within half a
    // voxel's diagonal): a part with none is transparent (culling, dvr_gl/renderers/splatting/splats.py)
    return vec4(v_splat.w * integral, closest2 <= 0.75 ? v_core : 0.0, 0.0, 0.0);
#endif
}

void main() {
#ifdef ERT
    if (texelFetch(u_accumulated, ivec2(gl_FragCoord.xy), 0).a >= u_ert)
        discard;  // this pixel is opaque already: early termination (renderer.py, Occlusion)
#endif
    vec3 o, d;
    camera_ray(o, d);
    float lo, hi;
    float along = dot(d, u_forward);  // the pixel ray's depth per unit length (before EWA's ray)
#ifdef PARTICLES
    // a particle smaller than a pixel is averaged over the pixel's square, whether or not the pixel's
    // centre ray meets its support (it lies in front of the near plane, inside the field's box)
    bool subpixel = v_particle.z > 0.5;
    if (!subpixel && !ray_extent(o, d, lo, hi))
        discard;
#else
    bool subpixel = false;
    if (!ray_extent(o, d, lo, hi))
        discard;
#endif
#if defined(FOOTPRINT_EWA) && !defined(CAMERA_ORTHOGRAPHIC)
    // EWA (Zwicker et al. 2001): the perspective map linearized at the kernel's centre.  The pixel's
    // screen offset from the centre's image goes through the inverse of that map's Jacobian into the
    // plane across the central ray, and the kernel is integrated along the parallel to the central
    // ray through that point (ray space); its parameters match the pixel ray's there.  A kernel at or
    // behind the eye has no such map: its pixels keep their own rays.
    vec3 p = v_splat.xyz - u_eye;
    float cz = dot(p, u_forward);
    vec3 central = normalize(p);
    if (cz > u_near && dot(d, central) > 0.1) {
        float cx = dot(p, u_right), cy = dot(p, u_up);
        vec3 e1 = normalize(cross(central, abs(dot(central, u_up)) < 0.9 ? u_up : u_right));
        vec3 e2 = cross(central, e1);
        // d(screen) / d(offset along e): ((e.right) z - x (e.forward)) / z^2 per half extent
        vec2 j1 = vec2((dot(e1, u_right) * cz - cx * dot(e1, u_forward)) / u_half_extent.x,
                       (dot(e1, u_up) * cz - cy * dot(e1, u_forward)) / u_half_extent.y) / (cz * cz);
        vec2 j2 = vec2((dot(e2, u_right) * cz - cx * dot(e2, u_forward)) / u_half_extent.x,
                       (dot(e2, u_up) * cz - cy * dot(e2, u_forward)) / u_half_extent.y) / (cz * cz);
        vec2 offset = (gl_FragCoord.xy / u_image_size * 2.0 - 1.0) - vec2(cx / u_half_extent.x, cy / u_half_extent.y) / cz;
        vec2 ab = inverse(mat2(j1, j2)) * offset;
        vec3 q = v_splat.xyz + ab.x * e1 + ab.y * e2;
        float at = dot(q - o, d);
        o = q - at * central;
        d = central;
    }
#endif
#ifdef SLAB_GROUP
    for (int s = 0; s < SLAB_GROUP; ++s) {
        float a = max(lo, u_group[s] / along), b = min(hi, u_group[s + 1] / along);
        frags[s] = (subpixel || b > a) ? contribution(o, d, a, b, vec2(u_group[s], u_group[s + 1]), subpixel)
                                       : vec4(0.0);
    }
#else
#ifdef SLABS
    vec4 share = contribution(o, d, lo, hi, u_slab, subpixel);
#else
    vec4 share = contribution(o, d, lo, hi, vec2(0.0), subpixel);
#endif
    if (all(equal(share, vec4(0.0))))
        discard;
    frag = share;
#endif
}
