// Clipping planes and a cropping box (dvr_gl.clipping): kept where n . x + d >= 0 for every plane
// (unit normals) and inside [u_clip_lo, u_clip_hi].  The region is convex, so a ray keeps one
// interval, narrowed here as dvr_gl.clipping.ClipRegion.interval narrows it; fragments of slices
// test clip_inside.  Defines: CLIPPING, NUM_CLIP_PLANES (0 ..), CLIP_BOX.
#include "common/box.glsl"

#if NUM_CLIP_PLANES > 0
uniform vec4 u_clip_planes[NUM_CLIP_PLANES];
#endif
#ifdef CLIP_BOX
uniform vec3 u_clip_lo;
uniform vec3 u_clip_hi;
#endif

// Narrow [t0, t1] of the ray o + t d to the kept region (empty: t1 <= t0).
void clip_interval(vec3 o, vec3 d, inout float t0, inout float t1) {
#ifdef CLIP_BOX
    float enter, leave;
    if (!intersect_box(o, d, u_clip_lo, u_clip_hi, enter, leave)) t1 = -3.0e38;
    t0 = max(t0, enter);
    t1 = min(t1, leave);
#endif
#if NUM_CLIP_PLANES > 0
    for (int i = 0; i < NUM_CLIP_PLANES; ++i) {
        float at_origin = dot(u_clip_planes[i].xyz, o) + u_clip_planes[i].w;
        float rate = dot(u_clip_planes[i].xyz, d);
        if (rate > 0.0) t0 = max(t0, -at_origin / rate);
        else if (rate < 0.0) t1 = min(t1, -at_origin / rate);
        else if (at_origin < 0.0) t1 = -3.0e38;
    }
#endif
}

// Whether world point p is kept (on a plane or a face: kept).
bool clip_inside(vec3 p) {
    bool keep = true;
#ifdef CLIP_BOX
    keep = all(greaterThanEqual(p, u_clip_lo)) && all(lessThanEqual(p, u_clip_hi));
#endif
#if NUM_CLIP_PLANES > 0
    for (int i = 0; i < NUM_CLIP_PLANES; ++i)
        keep = keep && dot(u_clip_planes[i].xyz, p) + u_clip_planes[i].w >= 0.0;
#endif
    return keep;
}
