#version 430 core
// A sheet buffer composited under what lies in front of it (front to back; blending
// ONE_MINUS_DST_ALPHA, ONE).  The sheet holds, per pixel, its kernels' integrals along the ray:
// post-classified, of the scalar (.r); pre-classified, of (sigma c, sigma).  XRAY (post-classified):
// the part's optical depth and emission (sigma c l, sigma l), added up (blending ONE, ONE).
// * SLABS (image-aligned): the integrals over the pixel's part of the slab inside the box; the
//   scalar's mean over the part is classified, the part is one segment of its length;
//   pre-classified, the part's optical depth and colour.
// * AXIS_SHEETS (Westover): the whole footprints of one voxel plane's kernels; the scalar's mean is
//   the sheet over the ray's length per plane (h / |d_axis|), and the segment is the ray's part
//   within half a spacing of the plane, inside the box; pre-classified, the sheet's optical depth.
#include "common/camera_ray.glsl"
#include "common/optics.glsl"
#include "common/transfer_function.glsl"
#include "kernel.glsl"
#include "common/shading.glsl"

uniform sampler2D u_sheet;
#if defined(SHADING) && defined(SLABS) && !defined(CLASSIFY_PRE)
// Shading, post-classified (Mueller, Moeller and Crawfis 1999): the gradient of the slab means in
// screen space, across from the neighbouring pixels' means at the pixel's size at the slab's middle
// depth, along the view from the slabs in front and behind (this sheet is composited one slab late);
// a mean is 0 where a part is empty and neighbours beyond the image repeat the edge.
uniform sampler2D u_sheet_prev;
uniform sampler2D u_sheet_next;

float slab_mean(sampler2D sheet, vec2 frag, vec2 slab) {
    frag = clamp(frag, vec2(0.5), u_image_size - 0.5);
    vec3 o, d;
    camera_ray_at(frag, o, d);
    float lo, hi;
    if (!ray_part(frag, o, d, slab, lo, hi))
        return 0.0;
    return texelFetch(sheet, ivec2(frag), 0).r / (hi - lo);
}

vec3 slab_gradient() {
    vec2 f = gl_FragCoord.xy;
    float w = u_slab.y - u_slab.x;
    float pixel = 2.0 * u_half_extent.x / u_image_size.x;  // world units across a pixel at the slab's middle
#ifndef CAMERA_ORTHOGRAPHIC
    pixel *= 0.5 * (u_slab.x + u_slab.y);
#endif
    float gx = (slab_mean(u_sheet, f + vec2(1.0, 0.0), u_slab) - slab_mean(u_sheet, f - vec2(1.0, 0.0), u_slab)) / (2.0 * pixel);
    float gy = (slab_mean(u_sheet, f + vec2(0.0, 1.0), u_slab) - slab_mean(u_sheet, f - vec2(0.0, 1.0), u_slab)) / (2.0 * pixel);
    float gz = (slab_mean(u_sheet_next, f, u_slab + w) - slab_mean(u_sheet_prev, f, u_slab - w)) / (2.0 * w);
    return gx * u_right + gy * u_up + gz * u_forward;
}
#endif
#ifdef AXIS_SHEETS
uniform vec3 u_spacing;
uniform int u_axis;
uniform float u_plane;   // the plane's coordinate along the axis, relative to the box's centre
#endif
out vec4 frag;

void main() {
    vec3 o, d;
    camera_ray(o, d);
    float lo, hi;
    if (!ray_extent(o, d, lo, hi))
        discard;
    vec4 sheet = texelFetch(u_sheet, ivec2(gl_FragCoord.xy), 0);
#ifdef AXIS_SHEETS
    float h = u_spacing[u_axis];
    float da = d[u_axis];
    float per_plane = h / max(abs(da), 1e-6);   // the ray's length between two planes
    float ta = (u_plane - 0.5 * h - o[u_axis]) / da;
    float tb = (u_plane + 0.5 * h - o[u_axis]) / da;
    lo = max(lo, min(ta, tb));
    hi = min(hi, max(ta, tb));
    float extent = hi - lo;                     // the ray's part near this plane, in the box
    if (!(extent > 0.0))
        discard;
#else
    float per_plane = hi - lo;
    float extent = hi - lo;
#endif
#ifdef CLASSIFY_PRE
    float tau = sheet.a;
    float alpha = opacity_of_depth(tau);
    vec3 colour = tau > 0.0 ? sheet.rgb / tau : vec3(0.0);
#else
#if defined(SLABS) && defined(CULLING)
    if (sheet.g <= 0.0)
        discard;  // no point of this part is near a core sample: its field is transparent (culling)
#endif
    vec4 optics = transfer_function(sheet.r / per_plane);
#ifdef XRAY
    float tau = optics.a * extent;  // the X-ray sums the parts' optical depth and emission
    frag = vec4(optics.rgb * tau, tau);
    return;
#endif
    float alpha = opacity_of_depth(optics.a * extent);
    vec3 colour = optics.rgb;
#if defined(SHADING) && defined(SLABS)
    colour = blinn_phong(colour, slab_gradient(), normalize(d));
#endif
#endif
    frag = vec4(colour * alpha, alpha);
}
