// Blocks of the acceleration structure (acceleration.py beside this folder), one texture per level:
// emission-absorption reads (colour, sigma) of constant blocks and sigma = -1 elsewhere;
// isosurface, MIP and MinIP read (min, max) of the values the filter can produce in a block.
// Level l blocks are u_block_size << l voxels wide; a sample at voxel coordinate u is in block
// floor(u / size).

uniform int u_block_size;
uniform sampler3D u_blocks0;
#if NUM_LEVELS > 1
uniform sampler3D u_blocks1;
#endif
#if NUM_LEVELS > 2
uniform sampler3D u_blocks2;
#endif
#if NUM_LEVELS > 3
uniform sampler3D u_blocks3;
#endif

ivec3 block_of(int level, vec3 u) {
    return ivec3(floor(u / float(u_block_size << level)));
}

vec4 block_fetch(int level, vec3 u) {
    ivec3 b = block_of(level, u);
#if NUM_LEVELS > 1
    if (level == 1) return texelFetch(u_blocks1, clamp(b, ivec3(0), textureSize(u_blocks1, 0) - 1), 0);
#endif
#if NUM_LEVELS > 2
    if (level == 2) return texelFetch(u_blocks2, clamp(b, ivec3(0), textureSize(u_blocks2, 0) - 1), 0);
#endif
#if NUM_LEVELS > 3
    if (level == 3) return texelFetch(u_blocks3, clamp(b, ivec3(0), textureSize(u_blocks3, 0) - 1), 0);
#endif
    return texelFetch(u_blocks0, clamp(b, ivec3(0), textureSize(u_blocks0, 0) - 1), 0);
}

// The coarsest level whose block around u passes `skippable` (-1 if level 0 does not), and that block;
// `block` comes in as the level-0 block (already fetched).  SKIPPABLE(block, bound) is defined by
// the including shader for its compositing mode.
int skip_level(vec3 u, float bound, inout vec4 block) {
    if (!SKIPPABLE(block, bound)) return -1;
    int level = 0;
    for (int l = 1; l < NUM_LEVELS; ++l) {
        vec4 up = block_fetch(l, u);
        if (!SKIPPABLE(up, bound)) break;
        block = up;
        level = l;
    }
    return level;
}

// Ray parameter from voxel position u inside the box [lo, hi], moving by dir voxels per unit t, to
// the face where the ray leaves the box (3e38 along no axis it moves on).
float box_exit_distance(vec3 lo, vec3 hi, vec3 u, vec3 dir) {
    vec3 face = mix(lo, hi, step(0.0, dir));
    bvec3 still = equal(dir, vec3(0.0));
    vec3 t = (face - u) / mix(dir, vec3(1.0), still);
    t = mix(t, vec3(3.0e38), still);
    return min(min(t.x, t.y), t.z);
}

// Ray parameter from voxel position u, moving by du voxels per unit t, to where the ray leaves
// (forward) or entered (backward) its block at `level`.
float block_exit_distance(int level, vec3 u, vec3 du) {
    float size = float(u_block_size << level);
    vec3 lo = floor(u / size) * size;
    return box_exit_distance(lo, lo + size, u, du);
}

float block_entry_distance(int level, vec3 u, vec3 du) {
    float size = float(u_block_size << level);
    vec3 lo = floor(u / size) * size;
    return box_exit_distance(lo, lo + size, u, -du);
}

// Segments k .. result - 1 have their samples inside the block the ray leaves at t_exit.
// floor, not ceil: a rounding error in t_exit may cost one sample, never skip one outside.
int segments_before(float t_exit, float t0, float offset, int k, int n) {
    return clamp(int(floor((t_exit - t0) / u_sample_distance - offset)), k + 1, n - 1);
}

// Segments result .. k have their samples inside the block the ray entered at t_entry
// (walking backward); one segment of margin against rounding.
int segments_after(float t_entry, float t0, float offset, int k) {
    return clamp(int(ceil((t_entry - t0) / u_sample_distance - offset)) + 1, 0, k);
}

// Runs (acceleration.run_keys): where a ray may sample on without another
// lookup.  Around each level-0 block, the neighbourhoods of Chebyshev radius RUN_RADII - 1 = 0, 1,
// 3, 7 blocks: where no block of one can be skipped, the ray samples on to its edge.  On dense data
// the loop then looks up once per ray or so instead of once per block.
//   RUNS_IN_CLASSES (emission-absorption, whose classes do not depend on the ray's state): the
//     level-0 class of a block that cannot be skipped holds -R, R the largest such radius (1, 2, 4
//     or 8), so the one fetch serves both; no runs texture.
//   otherwise: u_runs holds, per block, the mode's key reduced over each neighbourhood, and
//     RUN_DENSE(key) (the mode's) says whether no block there can be skipped for the state so far.
#ifndef RUNS_IN_CLASSES
uniform sampler3D u_runs;
#endif

// How far (ray parameter) from t at voxel position u the ray may sample without a lookup: to the
// exit (forward) or entry (backward) of the largest dense neighbourhood around u's block; 0 where
// u's own block may be skippable.  block0: u's level-0 block.
float dense_reach(vec3 u, vec3 du, vec4 block0) {
    ivec3 b = block_of(0, u);
#ifdef RUNS_IN_CLASSES
    float radius = max(-block0.a, 0.0);
#else
    vec4 key = texelFetch(u_runs, clamp(b, ivec3(0), textureSize(u_runs, 0) - 1), 0);
    float radius = RUN_DENSE(key.w) ? 8.0 : RUN_DENSE(key.z) ? 4.0 : RUN_DENSE(key.y) ? 2.0 :
                   RUN_DENSE(key.x) ? 1.0 : 0.0;
#endif
    if (radius == 0.0) return 0.0;
    float size = float(u_block_size);
#ifdef BACK_TO_FRONT
    vec3 dir = -du;
#else
    vec3 dir = du;
#endif
    return max(box_exit_distance((vec3(b) - (radius - 1.0)) * size, (vec3(b) + radius) * size, u, dir), 0.0);
}
