// A ray's intersection with an axis-aligned box (slab method, as dvr_gl.rays.intersect_box); included
// by camera_ray.glsl and scattering.glsl, once.
#ifndef COMMON_BOX_GLSL
#define COMMON_BOX_GLSL

// Entry and exit parameters of the closed box [lo, hi]; false when the ray misses it.
// A ray parallel to a slab is inside it for all t when its origin lies in the closed slab.
// Branchless (a per-axis loop with branches costs llvmpipe 6 % of a whole frame): the
// parallel axes' values, inf or NaN from dividing by zero, are replaced by selection.
bool intersect_box(vec3 o, vec3 d, vec3 lo, vec3 hi, out float t_enter, out float t_exit) {
    bvec3 parallel = equal(d, vec3(0.0));
    vec3 inv = 1.0 / mix(d, vec3(1.0), parallel);
    vec3 ta = (lo - o) * inv;
    vec3 tb = (hi - o) * inv;
    vec3 tmin = mix(min(ta, tb), vec3(-3.0e38), parallel);
    vec3 tmax = mix(max(ta, tb), vec3(3.0e38), parallel);
    t_enter = max(max(tmin.x, tmin.y), tmin.z);
    t_exit = min(min(tmax.x, tmax.y), tmax.z);
    bvec3 outside = bvec3(ivec3(lessThan(o, lo)) | ivec3(greaterThan(o, hi)));
    return !any(bvec3(ivec3(parallel) & ivec3(outside)));
}

#endif
