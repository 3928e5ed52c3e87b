#version 330 core
// GPU ray casting in one fragment loop; dvr_gl/renderers/raycast/renderer.py chooses the defines
// (shader_features), so a program holds exactly the features its scene uses.
//   compositing:     COMPOSITE_EMISSION [BACK_TO_FRONT] [XRAY] | COMPOSITE_ISOSURFACE |
//                    COMPOSITE_AVERAGE | COMPOSITE_MIP | COMPOSITE_MINIP
//   classification:  post (default) | CLASSIFY_PRE [ASSOCIATED_COLORS] | CLASSIFY_PREINTEGRATED
//   filters:         see common/volume_sample.glsl
//   options:         SHADING (NUM_LIGHTS, TWO_SIDED), GRADIENT_TEXTURE, GRADIENT_OPACITY, JITTER,
//                    EARLY_TERMINATION, SCATTERING (common/scattering.glsl), CLIPPING, GEOMETRY,
//                    ACCELERATE (NUM_LEVELS, RUNS_IN_CLASSES), RAY_BOUNDS, COUNT_SAMPLES,
//                    CAMERA_ORTHOGRAPHIC, BRICKED (one pass per brick, see below),
//                    DEPTH (= the output's location: the depth image, depth.glsl; never BRICKED)
//   several fields:  FIELDS (NUM_FIELDS, NUM_FIELD_GROUPS, ...: common/fields.glsl), the mixture per sample;
//                    their own isosurface and per-channel projections (fields_*.glsl); never BRICKED
// Segments and samples follow the conventions exactly as dvr_gl.reference.discrete places them.
//
// The program runs in stages, each a function with its own inputs and outputs (in these files):
//   1. ray set-up (ray.glsl): the ray, the kept part of it and its segments; segment(k) lays them out;
//   2. the pass window (window.glsl): the segments this pass walks (BRICKED: bricks.glsl; RAY_BOUNDS);
//   3. one walk per strategy: plain marching (march.glsl), or with empty-space skipping (ACCELERATE:
//      skipping.glsl); either walks k upward, or downward for BACK_TO_FRONT;
//   4. the resolve: the compositing state to the pixel (common/resolve.glsl; BRICKED: resolve.frag).
// BRICKED: the volume is in bricks (dvr_gl.renderers.grid.bricking), one pass each in visibility
// order; a pass composites the samples whose position lies in its brick's core (bricks.glsl),
// starting from the state the previous pass left in u_state (emission: colour and optical depth;
// projections: the running value; isosurface: the shaded hit, alpha 1, once found), and writes the
// new state; resolve.frag turns the last into the image.  Bricks carry enough ghost voxels for what
// a pass reads beyond its core (dvr_gl.renderers.grid.bricking.ghost_width).  Rays longer than
// llvmpipe's loop cap are composited the same way, in passes over windows of segments.
// COUNT_SAMPLES carries the counts between passes (u_counts).
//
// The compositing mode supplies its parts from one snippet (emission.glsl, emission_back_to_front.glsl,
// isosurface.glsl or projection.glsl), which keeps its state in globals and may read the ray's
// (o, d, t0, t1, offset, segment(k), sample_t(k): ray.glsl):
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
//                            (for the state so far)?  blocks.glsl's SKIPPABLE
//   bool mode_dense(float key)   ACCELERATE without RUNS_IN_CLASSES: blocks.glsl's RUN_DENSE
//   bool mode_jump(vec4 block, inout int m)   ACCELERATE: composite the next m segments, which
//                            lie in the block, without sampling them (mode_gap follows); may
//                            shorten m to where the ray is done, and returns whether it is
//   vec4 mode_finish(vec4 state)   after the loop: the new state (`state` as given to mode_init)

#if defined(SHADING) || defined(GRADIENT_OPACITY) || defined(TRANSFER_FUNCTION_2D)
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

#include "ray.glsl"
#define u_slab_length u_sample_distance  // the pre-integration table's segment length
uniform float u_unit_distance;       // projections: opacity over this length (world units)
uniform float u_ert_depth;           // optical depth at the early-termination opacity
uniform float u_iso_value;
uniform int u_iso_steps;
uniform float u_gradient_reference;  // GRADIENT_OPACITY: |gradient| giving full opacity

#ifdef BRICKED
#include "bricks.glsl"
#endif
#include "window.glsl"

layout(location = 0) out vec4 frag_color;
#ifdef COUNT_SAMPLES
layout(location = 1) out vec4 frag_samples;   // volume samples, block jumps, block lookups, segments jumped
#endif
#ifdef DEPTH
layout(location = DEPTH) out float frag_depth;  // depth.glsl
float depth_t = -1.0;  // the ray parameter of the pixel's depth, set by the mode parts (< 0: none yet)
int jump_from;         // ACCELERATE: the first segment of the run mode_jump composites
#endif

// preintegration.glsl here, not first inside #ifdef FIELDS: a file is expanded once, where it is first named
// (classify.glsl names it too; inside the #ifdef, one field's pre-integrated program would lose it)
#ifdef CLASSIFY_PREINTEGRATED
#include "common/preintegration.glsl"
#endif
#if defined(TRANSFER_FUNCTION_2D) || defined(FIELD_TABLES_2D)  // likewise: classify.glsl and fields.glsl name it
#include "common/transfer_function_2d.glsl"
#endif
#ifdef FIELDS
#include "common/fields.glsl"
#else
#include "common/classify.glsl"
// A segment's end value (pre-integration): one field's; several fields' is every member's (fields.glsl).
#define SegmentValue float
#define segment_value sample_scalar
#endif

#if defined(COMPOSITE_EMISSION) && defined(BACK_TO_FRONT)
#include "emission_back_to_front.glsl"
#elif defined(COMPOSITE_EMISSION)
#include "emission.glsl"
#elif defined(COMPOSITE_ISOSURFACE) && defined(FIELDS)
#include "fields_isosurface.glsl"
#elif defined(COMPOSITE_ISOSURFACE)
#include "isosurface.glsl"
#elif defined(FIELDS)
#include "fields_projection.glsl"
#else
#include "projection.glsl"
#endif

#include "march.glsl"
#ifdef DEPTH
#include "depth.glsl"
#endif
#ifdef ACCELERATE
#include "skipping.glsl"
#endif

void main() {
    start_counts();
#ifdef BRICKED
    vec4 state = texelFetch(u_state, ivec2(gl_FragCoord.xy), 0);  // the previous pass's
#else
    vec4 state = EMPTY_STATE;
#endif
    bool hit = set_up_ray();
    ivec2 window = pass_window(hit);  // BRICKED: false where the ray misses the brick
    if (hit && t1 > t0) {
        offset = sample_offset();
        bool done = mode_init(state);  // BRICKED: an earlier pass may have finished the ray
#ifdef ACCELERATE
        march_skipping(window, done);
#else
        march_every(window, done);
#endif
        state = mode_finish(state);
    }
#ifdef BRICKED
    frag_color = state;  // resolve.frag finishes it
#elif defined(FIELDS) && !defined(COMPOSITE_EMISSION)
    frag_color = state;  // several fields' projections and isosurface finish the pixel in mode_finish
#else
  #include "common/resolve.glsl"
#endif
#ifdef COUNT_SAMPLES
    frag_samples = vec4(samples, jumps, lookups, jumped);
#endif
#ifdef DEPTH
    frag_depth = pixel_depth();
#endif
}
