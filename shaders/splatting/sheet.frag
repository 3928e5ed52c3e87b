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
#include "splatting/kernel.glsl"

uniform sampler2D u_sheet;
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
#endif
    frag = vec4(colour * alpha, alpha);
}
