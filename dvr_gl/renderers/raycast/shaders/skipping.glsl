// Stage 3 of raycast.frag under ACCELERATE: marching with empty-space skipping.  It jumps runs of
// segments whose samples cannot change the result (blocks.glsl; the blocks are
// dvr_gl.renderers.raycast.acceleration's) without moving any sample, so the image stays the same to
// rounding.  BRICKED: blocks are looked up in the whole volume's textures at global voxel
// coordinates; a pass jumps only segments whose samples (pre-integrated: whole segments) lie
// CORE_MARGIN inside its brick's core, so that every brick's in_brick() agrees they are its own, and
// never past its window of segments.

#define SKIPPABLE(b, bound) mode_skippable(b)  // on the mode's own state: no bound needed
#define RUN_DENSE(key) mode_dense(key)
#include "blocks.glsl"

vec3 du;       // voxels (of block_voxel's coordinates) per world unit along d

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

// How far (world units along d) the ray, walking on from global voxel position u, stays CORE_MARGIN
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
// of blocks around it that has none to skip (blocks.glsl's dense_reach).  Reads the ray and du.
int segments_to_jump(int k, out vec4 block, out int run) {
    Segment s = segment(k);
#if !defined(CLASSIFY_PREINTEGRATED)
    float t_check = s.t;
    float run_offset = offset;
#elif defined(BACK_TO_FRONT)
    float t_check = s.start + s.len;
    float run_offset = 1.0;
#else
    float t_check = s.start;
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

// In the walking direction from segment k: how many segments are left in `window` (k's included),
// and where a run of `run` segments from k stops (the first segment past it, or past the window).
#ifdef BACK_TO_FRONT
int segments_left(int k, ivec2 window) { return k - window.x + 1; }
int run_stop(int k, int run, ivec2 window) { return max(k - run, window.x - 1); }
#else
int segments_left(int k, ivec2 window) { return window.y - k; }
int run_stop(int k, int run, ivec2 window) { return min(k + run, window.y); }
#endif

// Accelerated marching: the segments of `window` in the walking direction, until the ray is done
// (`done`: mode_init's answer).  An outer loop looks up the block at each step and either jumps
// the segments in it (mode_jump: the mode composites them in closed form, or not at all) or samples
// the run of segments it may sample without another lookup in an inner loop, whose body holds
// nothing but sampling (llvmpipe runs a loop body's every branch).  Reads the ray; the mode keeps
// the result in its state; counts lookups and jumps.
void march_skipping(ivec2 window, bool done) {
#ifdef BRICKED
    du = d * u_world_to_global_scale;  // blocks are level 0's (block_voxel)
#else
    du = d * u_world_to_voxel_scale;
#endif
    int k = first_segment(window);
    while (!done && in_window(k, window)) {
        vec4 block;
        int run;
        int m = segments_to_jump(k, block, run);
        lookups += 1.0;
        if (m > 0) {  // m segments in a skippable block: no samples
            // not past the pass's window or the ray bounds (the core's are clipped already)
            m = min(m, segments_left(k, window));
#ifdef DEPTH
            jump_from = k;
#endif
            done = mode_jump(block, m);
            mode_gap();
            k += STEP * m;
            jumps += 1.0;
            jumped += float(m);
            continue;
        }
        int k_stop = run_stop(k, run, window);
        mode_run(k);
        for (; !done && k != k_stop; k += STEP) done = take_segment(k);
    }
}
