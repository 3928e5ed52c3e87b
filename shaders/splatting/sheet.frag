#version 430 core
// A sheet buffer composited under what lies in front of it (front to back; blending
// ONE_MINUS_DST_ALPHA, ONE).  The sheet holds, per pixel, the slab's integrals along the ray:
// post-classified, of the scalar (.r): its mean over the slab's length inside the box is
// classified; pre-classified, of (sigma c, sigma): the slab's optical depth and colour.
#include "common/camera_ray.glsl"
#include "common/optics.glsl"
#include "common/transfer_function.glsl"
#include "splatting/kernel.glsl"

uniform sampler2D u_sheet;
out vec4 frag;

void main() {
    vec3 o, d;
    camera_ray(o, d);
    float lo, hi;
    if (!ray_extent(o, d, lo, hi))
        discard;
    vec4 sheet = texelFetch(u_sheet, ivec2(gl_FragCoord.xy), 0);
#ifdef CLASSIFY_PRE
    float tau = sheet.a;
    float alpha = opacity_of_depth(tau);
    vec3 colour = tau > 0.0 ? sheet.rgb / tau : vec3(0.0);
#else
    if (sheet.g <= 0.0)
        discard;  // no point of this part is near a core sample: its field is transparent (culling)
    float extent = hi - lo;
    vec4 optics = transfer_function(sheet.r / extent);
    float alpha = opacity_of_depth(optics.a * extent);
    vec3 colour = optics.rgb;
#endif
    frag = vec4(colour * alpha, alpha);
}
