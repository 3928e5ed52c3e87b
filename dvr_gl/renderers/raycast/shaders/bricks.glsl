// BRICKED: which samples a brick's pass owns (raycast.frag).  The volume is in bricks
// (dvr_gl.renderers.grid.bricking), one pass each in visibility order; a pass composites the samples
// whose position lies in its brick's core.  Ownership is decided in global (level-0) voxel
// coordinates, from the same uniforms in every pass (not from the brick's local ones), so that every
// pass rounds a point alike: each sample has exactly one owner.

uniform sampler2D u_state;      // the previous pass's state, this pixel
uniform vec3 u_world_to_global_scale;   // global (level-0) voxel coordinate = p * this + the offset: a
uniform vec3 u_world_to_global_offset;  // brick drawn from a coarser level (dvr_gl.multires) owns by level 0
uniform vec3 u_core_lo;         // the brick's core in global voxel coordinates: [lo, hi), or [lo, hi] where
uniform vec3 u_core_hi;         //   u_core_closed (the last brick along an axis)
uniform vec3 u_core_closed;
uniform vec3 u_brick_lo;        // and in world coordinates (to clip the ray)
uniform vec3 u_brick_hi;
uniform ivec2 u_segment_window;  // this pass's segments (llvmpipe caps a shader's loop iterations)

// The global voxel coordinates of world point p.
vec3 global_voxel(vec3 p) {
    return p * u_world_to_global_scale + u_world_to_global_offset;
}

// Samples with t in (sure_t0, sure_t1) (world units along d) are this brick's for sure: there the ray
// stays SURE_MARGIN voxels inside the core along every axis, far beyond in_brick's rounding.
float sure_t0, sure_t1;
const float SURE_MARGIN = 1.0 / 64.0;

// Does this brick own the sample at world point p?
bool in_brick(vec3 p) {
    vec3 g = global_voxel(p);
    ivec3 above = ivec3(greaterThanEqual(g, u_core_lo));
    ivec3 below = ivec3(lessThan(g, u_core_hi)) | (ivec3(equal(g, u_core_hi)) & ivec3(u_core_closed));
    return all(bvec3(above & below));
}

// Does this brick own the sample of segment k, at t (world units along d) and p = o + t d?  The exact
// test only near the core's faces: under llvmpipe's masks it cost a fifth of a bricked frame.
bool owns_sample(float t, vec3 p) {
    bool mine = t > sure_t0 && t < sure_t1;
    if (!mine) mine = in_brick(p);
    return mine;
}

// The entry point lies on the box, where rounding may put it a hair outside every core: the
// bricks at the volume's ends also own what lies just beyond them.
bool owns_entry(vec3 p) {
    vec3 g = global_voxel(p);
    ivec3 above = ivec3(greaterThanEqual(g, u_core_lo)) | ivec3(lessThanEqual(u_core_lo, vec3(0.0)));
    ivec3 below = ivec3(lessThan(g, u_core_hi)) | ivec3(u_core_closed);
    return all(bvec3(above & below));
}

// This pass's segments: reads the ray (o, d, t0, n), the brick's world box and u_segment_window;
// returns [first, last) segment indices, those whose samples may lie in the brick (one segment of
// margin either side) and in this window, and whether the ray meets the brick at all (`hit`).
ivec2 brick_window(inout bool hit) {
    float b0, b1;
    hit = hit && intersect_box(o, d, u_brick_lo, u_brick_hi, b0, b1);
    int k_first = clamp(int(floor((b0 - t0) / u_sample_distance)) - 1, 0, n);
    int k_last = clamp(int(ceil((b1 - t0) / u_sample_distance)) + 1, 0, n);
    return ivec2(max(k_first, u_segment_window.x), min(k_last, u_segment_window.y));
}

// Sets (sure_t0, sure_t1) from the ray (o, d): where the ray stays SURE_MARGIN inside the core along
// every axis its samples are this brick's whatever the rounding (in_brick's is far smaller than the
// margin), so owns_sample() needs no test there.
void find_sure_interval() {
    vec3 g0 = global_voxel(o), gd = d * u_world_to_global_scale;
    vec3 ta = (u_core_lo + SURE_MARGIN - g0) / gd, tb = (u_core_hi - SURE_MARGIN - g0) / gd;
    vec3 lo_t = min(ta, tb), hi_t = max(ta, tb);
    bvec3 still = equal(gd, vec3(0.0));  // parallel to an axis: inside its slab throughout, or never
    bvec3 in_slab = bvec3(vec3(greaterThan(g0, u_core_lo + SURE_MARGIN))
                          * vec3(lessThan(g0, u_core_hi - SURE_MARGIN)));
    lo_t = mix(lo_t, mix(vec3(3.0e38), vec3(-3.0e38), in_slab), still);  // selections: ta, tb may be inf, NaN
    hi_t = mix(hi_t, mix(vec3(-3.0e38), vec3(3.0e38), in_slab), still);
    sure_t0 = max(max(lo_t.x, lo_t.y), lo_t.z);
    sure_t1 = min(min(hi_t.x, hi_t.y), hi_t.z);
}
