#version 330 core
// GPU ray casting in one fragment loop; dvr_gl/renderers/raycast.py chooses the defines, so a
// program holds exactly the features its scene uses.
//   compositing:     COMPOSITE_EMISSION [BACK_TO_FRONT] | COMPOSITE_ISOSURFACE |
//                    COMPOSITE_AVERAGE | COMPOSITE_MIP | COMPOSITE_MINIP
//   classification:  post (default) | CLASSIFY_PRE [ASSOCIATED_COLORS] | CLASSIFY_PREINTEGRATED
//   filters:         see common/volume_sample.glsl
//   options:         SHADING (NUM_LIGHTS, TWO_SIDED), GRADIENT_TEXTURE, GRADIENT_OPACITY, JITTER,
//                    EARLY_TERMINATION, ACCELERATE (NUM_LEVELS), RAY_BOUNDS, COUNT_SAMPLES, CAMERA_ORTHOGRAPHIC,
//                    BRICKED (one pass per brick, see below)
// Segments and samples follow the conventions exactly as dvr_gl.reference.discrete places them;
// ACCELERATE jumps runs of segments whose samples cannot change the result (common/blocks.glsl)
// without moving any sample, so the image stays the same to rounding.
// BRICKED: the volume is in bricks (dvr_gl.bricking), one pass each in visibility order; a pass
// composites the samples whose position lies in its brick's core, starting from the state the
// previous pass left in u_state (emission: colour and optical depth; projections: the running
// value; isosurface: the shaded hit, alpha 1, once found), and writes the new state;
// shaders/resolve.frag turns the last into the image.  Bricks carry enough ghost voxels
// for what a pass reads beyond its core (dvr_gl.bricking.ghost_width).  Rays longer than
// llvmpipe's loop cap are composited the same way, in passes over windows of segments.
// ACCELERATE with BRICKED: blocks are looked up in the whole volume's textures at global voxel
// coordinates; a pass jumps only segments whose samples (pre-integrated: whole segments) lie
// CORE_MARGIN inside its brick's core, so that every brick's in_brick() agrees they are its own,
// and never past its window of segments.  COUNT_SAMPLES carries the counts between passes (u_counts).
//
// This file is the skeleton every mode shares: the ray and its segments, the pass's window, the
// loop over the segments (k upward, or downward for BACK_TO_FRONT; under ACCELERATE an outer loop
// of block lookups and an inner one sampling each run), brick ownership, block
// skipping, early termination, sample counting and the resolve.  The compositing mode supplies
// its parts from one snippet (raycast/emission.glsl, emission_back_to_front.glsl, isosurface.glsl
// or projection.glsl), which keeps its state in globals and may read the ray's (o, d, t0, t1,
// offset, sample_t below):
//   const vec4 EMPTY_STATE   the state of a ray before any sample (as the first pass's u_state)
//   bool mode_init(vec4 state)   before the loop: take over the state (the previous pass's, or
//                            EMPTY_STATE); true where the ray is done already (an earlier pass
//                            finished it; the isosurface's entry point is a hit)
//   bool mode_sample(int k, float start, float len, float t, vec3 p)   composite segment k,
//                            [start, start + len], sampled at t, p = o + t d; true where the ray
//                            is done (early termination, a hit)
//   void mode_gap()          the loop went past segments without sampling them (another brick's,
//                            or a jump): the next sample does not follow the last one
//   void mode_run(int k)     before a run of samples from segment k on (outside the sampling loop,
//                            whose body llvmpipe runs whole at every sample): what a run needs
//                            first (pre-integration: the value at the run's first segment end)
//   bool mode_skippable(vec4 block)   ACCELERATE: can no sample in the block change the result
//                            (for the state so far)?  common/blocks.glsl's SKIPPABLE
//   bool mode_jump(vec4 block, inout int m)   ACCELERATE: composite the next m segments, which
//                            lie in the block, without sampling them (mode_gap follows); may
//                            shorten m to where the ray is done, and returns whether it is
//   vec4 mode_finish(vec4 state)   after the loop: the new state (`state` as given to mode_init)

#if defined(SHADING) || defined(GRADIENT_OPACITY)
#define NEEDS_GRADIENT
#endif

#include "common/camera_ray.glsl"
#include "common/volume_sample.glsl"
#include "common/gradient.glsl"
#include "common/transfer_function.glsl"
#include "common/optics.glsl"
#include "common/shading.glsl"
#ifdef JITTER
#include "common/jitter.glsl"
#endif
#ifdef CLIPPING
#include "common/clipping.glsl"
#endif
#ifdef GEOMETRY
uniform sampler2D u_geometry;  // dvr_gl/renderers/surfaces.py: a = the nearest surface's t (3e38: none)
#endif

uniform vec3 u_box_lo;
uniform vec3 u_box_hi;
uniform float u_sample_distance;     // world units
#define u_slab_length u_sample_distance  // the pre-integration table's segment length
uniform float u_unit_distance;       // projections: opacity over this length
uniform float u_ert_depth;           // optical depth at the early-termination opacity
uniform float u_iso_value;
uniform int u_iso_steps;
uniform float u_gradient_reference;  // GRADIENT_OPACITY: |gradient| giving full opacity

#ifdef BRICKED
uniform sampler2D u_state;      // the previous pass's state, this pixel
uniform vec3 u_world_to_global_scale;   // global (level-0) voxel coordinate = p * this + the offset: a
uniform vec3 u_world_to_global_offset;  // brick drawn from a coarser level (dvr_gl.multires) owns by level 0
uniform vec3 u_core_lo;         // the brick's core in global voxel coordinates: [lo, hi), or [lo, hi] where
uniform vec3 u_core_hi;         //   u_core_closed (the last brick along an axis)
uniform vec3 u_core_closed;
uniform vec3 u_brick_lo;        // and in world coordinates (to clip the ray)
uniform vec3 u_brick_hi;
uniform ivec2 u_segment_window;  // this pass's segments (llvmpipe caps a shader's loop iterations)

// Global voxel coordinates, computed from the same uniforms in every pass (not from the brick's
// local ones), so that every pass rounds a point alike: each sample has exactly one owner.
vec3 global_voxel(vec3 p) {
    return p * u_world_to_global_scale + u_world_to_global_offset;
}

// Samples with t in (sure_t0, sure_t1) are this brick's for sure: there the ray stays SURE_MARGIN
// voxels inside the core along every axis, far beyond in_brick's rounding (see main).
float sure_t0, sure_t1;
const float SURE_MARGIN = 1.0 / 64.0;

// Does this brick own the sample at p?
bool in_brick(vec3 p) {
    vec3 g = global_voxel(p);
    ivec3 above = ivec3(greaterThanEqual(g, u_core_lo));
    ivec3 below = ivec3(lessThan(g, u_core_hi)) | (ivec3(equal(g, u_core_hi)) & ivec3(u_core_closed));
    return all(bvec3(above & below));
}

// The entry point lies on the box, where rounding may put it a hair outside every core: the
// bricks at the volume's ends also own what lies just beyond them.
bool owns_entry(vec3 p) {
    vec3 g = global_voxel(p);
    ivec3 above = ivec3(greaterThanEqual(g, u_core_lo)) | ivec3(lessThanEqual(u_core_lo, vec3(0.0)));
    ivec3 below = ivec3(lessThan(g, u_core_hi)) | ivec3(u_core_closed);
    return all(bvec3(above & below));
}
#endif

#ifdef RAY_BOUNDS
uniform sampler2D u_ray_bounds;  // (first entry, -last exit) of the non-empty blocks, this pixel
#endif

layout(location = 0) out vec4 frag_color;
#ifdef COUNT_SAMPLES
layout(location = 1) out vec4 frag_samples;   // volume samples, block jumps, block lookups, segments jumped
#ifdef BRICKED
uniform sampler2D u_counts;     // the counts of the passes before, this pixel
#endif
#endif

#include "common/classify.glsl"

// The ray, set up by main() before the mode parts run: points o + t d (d of unit length), the box
// from t0 to t1 in n segments of u_sample_distance (the last shortened to end at t1), each
// sampled at `offset` (0.5, or jittered) of its length.
vec3 o, d;
float t0, t1, offset;
int n;

// Parameter of the sample of segment k.
float sample_t(int k) {
    float start = t0 + float(k) * u_sample_distance;
    return start + offset * min(u_sample_distance, t1 - start);
}

#if defined(COMPOSITE_EMISSION) && defined(BACK_TO_FRONT)
#include "emission_back_to_front.glsl"
#elif defined(COMPOSITE_EMISSION)
#include "emission.glsl"
#elif defined(COMPOSITE_ISOSURFACE)
#include "isosurface.glsl"
#else
#include "projection.glsl"
#endif

#ifdef BACK_TO_FRONT
#define STEP (-1)   // the walking direction along k
#else
#define STEP 1
#endif

#ifdef ACCELERATE
#define SKIPPABLE(b, bound) mode_skippable(b)  // on the mode's own state: no bound needed
#define RUN_DENSE(key) mode_dense(key)
#include "common/blocks.glsl"

vec3 du;       // voxels per unit of t

// Where blocks are looked up: the pyramid and runs textures are the whole volume's, so a brick's
// pass uses global voxel coordinates (voxel_coord() is its texture's); without bricks the two are one.
#ifdef BRICKED
#define block_voxel global_voxel
#else
#define block_voxel voxel_coord
#endif

#ifdef BRICKED
// Voxels: jumps keep this far inside the core, far more than the rounding of any position there
// (a few ulps of the global coordinate: 1e-3 voxel at 8192), so that the samples a pass jumps are
// ones in_brick() gives to its brick in every pass; a sample nearer a core face is looked at alone.
const float CORE_MARGIN = 1.0 / 64.0;

// How far (ray parameter) the ray, walking on from global voxel position u, stays CORE_MARGIN
// inside the brick's core; 0 where u is not that far inside.
float core_reach(vec3 u) {
    vec3 lo = u_core_lo + CORE_MARGIN, hi = u_core_hi - CORE_MARGIN;
    if (any(lessThan(u, lo)) || any(greaterThan(u, hi))) return 0.0;
#ifdef BACK_TO_FRONT
    vec3 dir = -du;
#else
    vec3 dir = du;
#endif
    return max(box_exit_distance(lo, hi, u, dir), 0.0);
}
#endif

// The ray parameter where, walking from t at voxel position u, the ray leaves the block at `level`.
float block_end(float t, int level, vec3 u) {
#ifdef BACK_TO_FRONT
    return t - block_entry_distance(level, u, du);
#else
    return t + block_exit_distance(level, u, du);
#endif
}

// How many segments, k and on in the walking direction, the loop may jump (0: sample segment k),
// and the block they lie in.  The block is the one around the sample or, for pre-integrated
// segments (which must lie in it whole), around the end of segment k met first.  Never the
// shortened last segment.  Where segment k is to be sampled, `run` is how many segments from k on
// may be sampled before the next lookup: those whose check point lies in the largest neighbourhood
// of blocks around it that has none to skip (common/blocks.glsl's dense_reach).
int segments_to_jump(int k, out vec4 block, out int run) {
    float start = t0 + float(k) * u_sample_distance;  // segment k (as sample_t)
    float len = min(u_sample_distance, t1 - start);
#if !defined(CLASSIFY_PREINTEGRATED)
    float t_check = start + offset * len;
    float run_offset = offset;
#elif defined(BACK_TO_FRONT)
    float t_check = start + len;
    float run_offset = 1.0;
#else
    float t_check = start;
    float run_offset = 0.0;
#endif
    run = 1;
    if (k >= n - 1) return 0;
    vec3 u_check = block_voxel(o + t_check * d);
    // The segments whose check point lies within `reach` of t_check; rounding only shortens or
    // lengthens a run by one segment, which moves a lookup, never a sample.
    block = block_fetch(0, u_check);
    float reach = dense_reach(u_check, du, block);
    if (reach > 0.0) {
#ifdef BACK_TO_FRONT
        run = k - int(floor((t_check - reach - t0) / u_sample_distance - run_offset));
#else
        run = int(ceil((t_check + reach - t0) / u_sample_distance - run_offset)) - k;
#endif
        run = max(run, 1);
        return 0;
    }
#ifdef BRICKED
    // Jump only this brick's segments: clip the block at the core (sample k itself must be inside).
    float inside = core_reach(u_check);
    if (inside <= 0.0) return 0;
#endif
    int level = skip_level(u_check, 0.0, block);
    if (level < 0) return 0;  // a guard: dense_reach is 0 only where level 0 is skippable
    float t_end = block_end(t_check, level, u_check);
#if defined(BRICKED) && defined(BACK_TO_FRONT)
    t_end = max(t_end, t_check - inside);
#elif defined(BRICKED)
    t_end = min(t_end, t_check + inside);
#endif
#if defined(BACK_TO_FRONT) && defined(CLASSIFY_PREINTEGRATED)
    int k_begin = max(int(ceil((t_end - t0) / u_sample_distance)) + 1, 0);
    int m = k_begin < k ? k - k_begin + 1 : 0;
#elif defined(BACK_TO_FRONT)
    int m = k - segments_after(t_end, t0, offset, k) + 1;
#elif defined(CLASSIFY_PREINTEGRATED)
    int m = max(min(int(floor((t_end - t0) / u_sample_distance)) - 1, n - 1) - k, 0);
#else
    int m = segments_before(t_end, t0, offset, k, n) - k;
#endif
    return m;
}
#endif

void main() {
    float samples = 0.0, jumps = 0.0, lookups = 0.0, jumped = 0.0;
#if defined(BRICKED) && defined(COUNT_SAMPLES)
    vec4 counted = texelFetch(u_counts, ivec2(gl_FragCoord.xy), 0);
    samples = counted.x;
    jumps = counted.y;
    lookups = counted.z;
    jumped = counted.w;
#endif
#ifdef BRICKED
    vec4 state = texelFetch(u_state, ivec2(gl_FragCoord.xy), 0);
#else
    vec4 state = EMPTY_STATE;
#endif
    camera_ray(o, d);
    bool hit = intersect_box(o, d, u_box_lo, u_box_hi, t0, t1);
#ifdef CLIPPING
    clip_interval(o, d, t0, t1);  // the kept part of the ray, sampled as the box's is
#endif
#ifdef GEOMETRY
    t1 = min(t1, texelFetch(u_geometry, ivec2(gl_FragCoord.xy), 0).a);  // ends at an opaque surface
#endif
    t0 = max(t0, near_distance(d));
    // Segments k_first .. k_last - 1 are this pass's (all of them without bricks).
    n = max(int(ceil((t1 - t0) / u_sample_distance)), 1);  // from the ray's length: no loop cap
    int k_first = 0, k_last = n;
#ifdef BRICKED
    float b0, b1;
    hit = hit && intersect_box(o, d, u_brick_lo, u_brick_hi, b0, b1);
    k_first = clamp(int(floor((b0 - t0) / u_sample_distance)) - 1, 0, n);
    k_last = clamp(int(ceil((b1 - t0) / u_sample_distance)) + 1, 0, n);
    k_first = max(k_first, u_segment_window.x);
    k_last = min(k_last, u_segment_window.y);
    // Where the ray stays SURE_MARGIN inside the core along every axis its samples are this brick's
    // whatever the rounding (in_brick's is far smaller than the margin): no test there.
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
#endif
#ifdef RAY_BOUNDS
    // Only the segments from one before the ray's first entry into a non-empty block to one after
    // its last exit (ray_bounds.frag); those left out lie in empty blocks and add exactly nothing.
    // The margin of a segment covers the bounds' rounding; no faces crossed: +inf, -(-inf).
    vec2 bounds = texelFetch(u_ray_bounds, ivec2(gl_FragCoord.xy), 0).xy;
    k_first = max(k_first, int(clamp(floor((bounds.x - t0) / u_sample_distance) - 1.0, 0.0, float(n))));
    k_last = min(k_last, int(clamp(ceil((-bounds.y - t0) / u_sample_distance) + 1.0, 0.0, float(n))));
#endif
    if (hit && t1 > t0) {
#ifdef JITTER
        offset = jitter_offset();
#else
        offset = 0.5;
#endif
#ifdef ACCELERATE
#ifdef BRICKED
        du = d * u_world_to_global_scale;  // blocks are level 0's (block_voxel)
#else
        du = d * u_world_to_voxel_scale;
#endif
#endif
        bool done = mode_init(state);  // BRICKED: an earlier pass may have finished the ray
#ifdef BACK_TO_FRONT
        int k = k_last - 1;
#else
        int k = k_first;
#endif
#ifndef ACCELERATE
        if (k_first < k_last) mode_run(k);  // one run: every segment
#endif
#ifdef BACK_TO_FRONT
        while (!done && k >= k_first) {
#else
        while (!done && k < k_last) {
#endif
            int run = 1;
#ifdef ACCELERATE
            // Once per block: jump it, or sample the run of segments inside it in the inner loop,
            // whose body holds nothing but sampling (llvmpipe runs a loop body's every branch).
            vec4 block;
            int m = segments_to_jump(k, block, run);
            lookups += 1.0;
            if (m > 0) {  // m segments in a skippable block: no samples
                // not past the pass's window or the ray bounds (the core's are clipped already)
#ifdef BACK_TO_FRONT
                m = min(m, k - k_first + 1);
#else
                m = min(m, k_last - k);
#endif
                done = mode_jump(block, m);
                mode_gap();
                k += STEP * m;
                jumps += 1.0;
                jumped += float(m);
                continue;
            }
#ifdef BACK_TO_FRONT
            int k_stop = max(k - run, k_first - 1);
#else
            int k_stop = min(k + run, k_last);
#endif
            mode_run(k);
            for (; !done && k != k_stop; k += STEP) {
#endif
            float start = t0 + float(k) * u_sample_distance;  // segment k (as sample_t)
            float len = min(u_sample_distance, t1 - start);
            float t = start + offset * len;
            vec3 p = o + t * d;
#ifdef BRICKED
            bool mine = t > sure_t0 && t < sure_t1;  // the exact test only near the core's faces: under
            if (!mine) mine = in_brick(p);           // llvmpipe's masks it cost a fifth of a bricked frame
            if (mine) {
                done = mode_sample(k, start, len, t, p);
                samples += 1.0;
            } else {
                mode_gap();  // another brick's sample
            }
#else
            done = mode_sample(k, start, len, t, p);
            samples += 1.0;
#endif
#ifdef ACCELERATE
            }
#else
            k += STEP;
#endif
        }
        state = mode_finish(state);
    }
#ifdef BRICKED
    frag_color = state;  // raycast_resolve.frag finishes it
#else
  #include "common/resolve.glsl"
#endif
#ifdef COUNT_SAMPLES
    frag_samples = vec4(samples, jumps, lookups, jumped);
#endif
}
