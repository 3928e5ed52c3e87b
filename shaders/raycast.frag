#version 330 core
// GPU ray casting in one fragment loop; dvr_gl/renderers/raycast.py chooses the defines, so a
// program holds exactly the features its scene uses.
//   compositing:     COMPOSITE_EMISSION [BACK_TO_FRONT] | COMPOSITE_ISOSURFACE |
//                    COMPOSITE_AVERAGE | COMPOSITE_MIP | COMPOSITE_MINIP
//   classification:  post (default) | CLASSIFY_PRE [ASSOCIATED_COLORS] | CLASSIFY_PREINTEGRATED
//   filters:         see common/volume_sample.glsl
//   options:         SHADING (NUM_LIGHTS, TWO_SIDED), GRADIENT_TEXTURE, GRADIENT_OPACITY, JITTER,
//                    EARLY_TERMINATION, ACCELERATE (NUM_LEVELS), COUNT_SAMPLES, CAMERA_ORTHOGRAPHIC,
//                    BRICKED (one pass per brick, see below)
// Segments and samples follow the conventions exactly as dvr_gl.reference.discrete places them;
// ACCELERATE jumps runs of segments whose samples cannot change the result (common/blocks.glsl)
// without moving any sample, so the image stays the same to rounding.
// BRICKED: the volume is in bricks (dvr_gl.bricking), one pass each in visibility order; a pass
// composites the samples whose position lies in its brick's core, starting from the state the
// previous pass left in u_state (emission: colour and optical depth; projections: the running
// value; isosurface: the shaded hit, alpha 1, once found), and writes the new state;
// shaders/raycast_resolve.frag turns the last into the image.  Bricks carry enough ghost voxels
// for what a pass reads beyond its core (dvr_gl.bricking.ghost_width).

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

uniform vec3 u_box_lo;
uniform vec3 u_box_hi;
uniform float u_sample_distance;     // world units
#define u_slab_length u_sample_distance  // the pre-integration table's segment length
uniform float u_unit_distance;       // projections: opacity over this length
uniform float u_ert_depth;           // optical depth at the early-termination opacity
uniform float u_iso_value;
uniform int u_iso_steps;
uniform float u_gradient_reference;  // GRADIENT_OPACITY: |gradient| giving full opacity

#ifdef ACCELERATE
  // Which blocks a ray may jump: constant (colour, sigma) for emission; values that cannot reach
  // the iso-value, raise the maximum or lower the minimum for the others.
  #if defined(COMPOSITE_EMISSION)
    #define SKIPPABLE(b, bound) ((b).a >= 0.0)
  #elif defined(COMPOSITE_ISOSURFACE)
    #define SKIPPABLE(b, bound) ((b).y < u_iso_value)
  #elif defined(COMPOSITE_MIP)
    #define SKIPPABLE(b, bound) ((b).y <= (bound))
  #elif defined(COMPOSITE_MINIP)
    #define SKIPPABLE(b, bound) ((b).x >= (bound))
  #endif
#include "common/blocks.glsl"
#endif


#ifdef BRICKED
uniform sampler2D u_state;      // the previous pass's state, this pixel
uniform vec3 u_world_to_global_offset;  // global voxel coordinate = p * u_world_to_voxel_scale + this
uniform vec3 u_core_lo;         // the brick's core in global voxel coordinates: [lo, hi), or [lo, hi] where
uniform vec3 u_core_hi;         //   u_core_closed (the last brick along an axis)
uniform vec3 u_core_closed;
uniform vec3 u_brick_lo;        // and in world coordinates (to clip the ray)
uniform vec3 u_brick_hi;
uniform ivec2 u_segment_window;  // this pass's segments (llvmpipe caps a shader's loop iterations)

// Global voxel coordinates, computed from the same uniforms in every pass (not from the brick's
// local ones), so that every pass rounds a point alike: each sample has exactly one owner.
vec3 global_voxel(vec3 p) {
    return p * u_world_to_voxel_scale + u_world_to_global_offset;
}

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

layout(location = 0) out vec4 frag_color;
#ifdef COUNT_SAMPLES
layout(location = 1) out vec2 frag_samples;   // volume samples, block jumps
#endif

#include "common/classify.glsl"

// Parameter of the sample of segment k (the last segment is shortened to end at t1).
float sample_t(int k, float t0, float t1, float offset) {
    float start = t0 + float(k) * u_sample_distance;
    return start + offset * min(u_sample_distance, t1 - start);
}

void main() {
    float samples = 0.0, jumps = 0.0;
#ifdef BRICKED
    vec4 state = texelFetch(u_state, ivec2(gl_FragCoord.xy), 0);
#else
    vec4 state = vec4(0.0);
  #if defined(COMPOSITE_MIP)
    state.x = -3.0e38;
  #elif defined(COMPOSITE_MINIP)
    state.x = 3.0e38;
  #endif
#endif
    vec3 o, d;
    camera_ray(o, d);
    float t0, t1;
    bool hit = intersect_box(o, d, u_box_lo, u_box_hi, t0, t1);
    t0 = max(t0, near_distance(d));
    // Segments k_first .. k_last - 1 are this pass's (all of them without bricks).
    int n = max(int(ceil((t1 - t0) / u_sample_distance)), 1);  // from the ray's length: no loop cap
    int k_first = 0, k_last = n;
#ifdef BRICKED
    float b0, b1;
    hit = hit && intersect_box(o, d, u_brick_lo, u_brick_hi, b0, b1);
    k_first = clamp(int(floor((b0 - t0) / u_sample_distance)) - 1, 0, n);
    k_last = clamp(int(ceil((b1 - t0) / u_sample_distance)) + 1, 0, n);
    k_first = max(k_first, u_segment_window.x);
    k_last = min(k_last, u_segment_window.y);
  #if defined(COMPOSITE_EMISSION) && defined(EARLY_TERMINATION)
    hit = hit && state.a < u_ert_depth;  // terminated in an earlier brick
  #elif defined(COMPOSITE_ISOSURFACE)
    hit = hit && state.a == 0.0;         // an earlier brick found the surface
  #endif
#endif
    if (hit && t1 > t0) {
#ifdef JITTER
        float offset = jitter_offset();
#else
        float offset = 0.5;
#endif
#ifdef ACCELERATE
        vec3 du = d * u_world_to_voxel_scale;  // voxels per unit of t
        vec4 block;
        // Samples before (after, walking backward) this parameter lie in a level-0 block already
        // found not skippable: no need to fetch it again.  Rounding can only delay a jump.
        float known_until = -3.0e38;
        float known_from = 3.0e38;
#endif

#if defined(COMPOSITE_EMISSION) && !defined(BACK_TO_FRONT)
        vec3 colour = state.rgb;
        float depth = state.a;  // accumulated optical depth: transmittance is exp(-depth)
  #ifdef CLASSIFY_PREINTEGRATED
        float front = 0.0;
        bool front_known = false;  // the front value of segment k is the back value of segment k - 1
  #endif
        int k = k_first;
        while (k < k_last) {
            float t = sample_t(k, t0, t1, offset);
            vec3 p = o + t * d;
  #ifdef BRICKED
            if (!in_brick(p)) { k += 1; continue; }
  #endif
  #ifdef ACCELERATE
    #ifdef CLASSIFY_PREINTEGRATED
            float t_check = t0 + float(k) * u_sample_distance;  // whole segments: from their start
    #else
            float t_check = t;
    #endif
            vec3 u_check = voxel_coord(o + t_check * d);
            int level = -1;
            if (k < n - 1 && t_check >= known_until) {
                level = skip_level(u_check, 0.0, block);
                if (level < 0) known_until = t_check + block_exit_distance(0, u_check, du);
            }
    #ifdef CLASSIFY_PREINTEGRATED
            int k_end = level < 0 ? k : min(int(floor((t_check + block_exit_distance(level, u_check, du) - t0)
                                                      / u_sample_distance)) - 1, n - 1);
            if (k_end <= k) level = -1;  // the segment leaves the block: sample it
    #else
            int k_end = level < 0 ? k : segments_before(t + block_exit_distance(level, u_check, du), t0, offset, k, n);
    #endif
            if (level >= 0) {  // m segments of constant (colour, sigma): closed form, as stepping sums
                float m = float(k_end - k);
                float tau = block.a * u_sample_distance;
    #ifdef EARLY_TERMINATION
                if (tau > 0.0) m = min(m, ceil((u_ert_depth - depth) / tau));  // where stepping stops
    #endif
                colour += exp(-depth) * opacity_of_depth(tau * m) * block.rgb;
                depth += tau * m;
                k += int(m);
                jumps += 1.0;
    #ifdef CLASSIFY_PREINTEGRATED
                front_known = false;
    #endif
    #ifdef EARLY_TERMINATION
                if (depth >= u_ert_depth) break;
    #endif
                continue;
            }
  #endif
            float start = t0 + float(k) * u_sample_distance;
            float len = min(u_sample_distance, t1 - start);
  #ifdef CLASSIFY_PREINTEGRATED
            if (!front_known) front = sample_scalar(o + start * d);
            float back = sample_scalar(o + (start + len) * d);
            vec4 e = preintegrated_segment(front, back, len, p, d);
            front = back;
            front_known = true;
            colour += exp(-depth) * e.rgb;
            depth += e.a;
  #else
            vec4 cs = classify(p, d);
            float tau = cs.a * len;
            colour += exp(-depth) * opacity_of_depth(tau) * cs.rgb;
            depth += tau;
  #endif
            samples += 1.0;
            k += 1;
  #ifdef EARLY_TERMINATION
            if (depth >= u_ert_depth) break;
  #endif
        }
        state = vec4(colour, depth);

#elif defined(COMPOSITE_EMISSION)
        vec4 acc = state;  // the over operator, from the last segment to the first
  #ifdef CLASSIFY_PREINTEGRATED
        float back = 0.0;
        bool back_known = false;  // the back value of segment k is the front value of segment k + 1
  #endif
        int k = k_last - 1;
        while (k >= k_first) {
            float t = sample_t(k, t0, t1, offset);
            vec3 p = o + t * d;
  #ifdef BRICKED
            if (!in_brick(p)) { k -= 1; continue; }
  #endif
            float start = t0 + float(k) * u_sample_distance;
            float len = min(u_sample_distance, t1 - start);
  #ifdef ACCELERATE
    #ifdef CLASSIFY_PREINTEGRATED
            float t_check = start + len;  // whole segments: from their end
    #else
            float t_check = t;
    #endif
            vec3 u_check = voxel_coord(o + t_check * d);
            int level = -1;
            if (k < n - 1 && t_check <= known_from) {
                level = skip_level(u_check, 0.0, block);
                if (level < 0) known_from = t_check - block_entry_distance(0, u_check, du);
            }
    #ifdef CLASSIFY_PREINTEGRATED
            int k_begin = level < 0 ? k : max(int(ceil((t_check - block_entry_distance(level, u_check, du) - t0)
                                                       / u_sample_distance)) + 1, 0);
            if (k_begin >= k) level = -1;  // the segment leaves the block: sample it
    #else
            int k_begin = level < 0 ? k : segments_after(t - block_entry_distance(level, u_check, du), t0, offset, k);
    #endif
            if (level >= 0) {
                float alpha = opacity_of_depth(block.a * u_sample_distance * float(k - k_begin + 1));
                acc = vec4(block.rgb * alpha, alpha) + (1.0 - alpha) * acc;
                k = k_begin - 1;
                jumps += 1.0;
    #ifdef CLASSIFY_PREINTEGRATED
                back_known = false;
    #endif
                continue;
            }
  #endif
  #ifdef CLASSIFY_PREINTEGRATED
            if (!back_known) back = sample_scalar(o + (start + len) * d);
            float front = sample_scalar(o + start * d);
            vec4 e = preintegrated_segment(front, back, len, p, d);
            back = front;
            back_known = true;
            float alpha = opacity_of_depth(e.a);
            acc = vec4(e.rgb, alpha) + (1.0 - alpha) * acc;
  #else
            vec4 cs = classify(p, d);
            float alpha = opacity_of_depth(cs.a * len);
            acc = vec4(cs.rgb * alpha, alpha) + (1.0 - alpha) * acc;
  #endif
            samples += 1.0;
            k -= 1;
        }
        state = acc;

#elif defined(COMPOSITE_ISOSURFACE)
        // The first point with value >= iso among the entry point and the samples.  (ta, sa) is the
        // last point looked at; where it is not the sample just before segment k (after a jump, or
        // in a brick's first sample), a hit re-reads it, so the bisection bracket is always the same.
        // BRICKED: a pass looks at the points its brick owns, the bracket's start in its ghost voxels.
        float ta = t0, sa = 0.0;
        float tb = t0, sb = 0.0;
        bool found = false;
        bool previous_known = false;
  #ifdef BRICKED
        if (owns_entry(o + t0 * d)) {
  #endif
            sa = sample_scalar(o + t0 * d);
            sb = sa;
            found = sa >= u_iso_value;
            previous_known = true;
  #ifdef BRICKED
        }
  #endif
        int k = k_first;
        while (k < k_last && !found) {
            float t = sample_t(k, t0, t1, offset);
  #ifdef BRICKED
            if (!in_brick(o + t * d)) { k += 1; previous_known = false; continue; }
  #endif
  #ifdef ACCELERATE
            int level = -1;
            if (k < n - 1 && t >= known_until) {
                level = skip_level(voxel_coord(o + t * d), 0.0, block);
                if (level < 0) known_until = t + block_exit_distance(0, voxel_coord(o + t * d), du);
            }
            if (level >= 0) {  // no value in the block reaches iso
                k = segments_before(t + block_exit_distance(level, voxel_coord(o + t * d), du), t0, offset, k, n);
                previous_known = false;
                jumps += 1.0;
                continue;
            }
  #endif
            float s = sample_scalar(o + t * d);
            samples += 1.0;
            if (s >= u_iso_value) {
                tb = t;
                sb = s;
                found = true;
                if (!previous_known) {
                    ta = k > 0 ? sample_t(k - 1, t0, t1, offset) : t0;
                    sa = sample_scalar(o + ta * d);
                }
            } else {
                ta = t;
                sa = s;
                previous_known = true;
            }
            k += 1;
        }
        if (found) {
            for (int i = 0; i < u_iso_steps; ++i) {  // bisection keeps s(ta) < iso <= s(tb)
                float tm = 0.5 * (ta + tb);
                float sm = sample_scalar(o + tm * d);
                if (sm >= u_iso_value) { tb = tm; sb = sm; } else { ta = tm; sa = sm; }
            }
            float w = sb > sa ? clamp((u_iso_value - sa) / (sb - sa), 0.0, 1.0) : 1.0;
            vec3 p = o + (ta + w * (tb - ta)) * d;
            vec3 colour = transfer_function(u_iso_value).rgb;
  #ifdef SHADING
            colour = blinn_phong(colour, gradient(p), d);
  #endif
            state = vec4(colour, 1.0);
        }

#else
        float acc = state.x, total = state.y;  // the running maximum, minimum, or sum and length
        int k = k_first;
        while (k < k_last) {
            float t = sample_t(k, t0, t1, offset);
  #ifdef BRICKED
            if (!in_brick(o + t * d)) { k += 1; continue; }
  #endif
  #ifdef ACCELERATE
            int level = -1;
            if (k < n - 1 && t >= known_until) {  // a block rechecked later may pass: the bound moved
                level = skip_level(voxel_coord(o + t * d), acc, block);
                if (level < 0) known_until = t + block_exit_distance(0, voxel_coord(o + t * d), du);
            }
            if (level >= 0) {  // the block cannot raise the maximum (lower the minimum)
                k = segments_before(t + block_exit_distance(level, voxel_coord(o + t * d), du), t0, offset, k, n);
                jumps += 1.0;
                continue;
            }
  #endif
            float s = sample_scalar(o + t * d);
  #if defined(COMPOSITE_AVERAGE)
            float len = min(u_sample_distance, t1 - (t0 + float(k) * u_sample_distance));
            acc += s * len;
            total += len;
  #elif defined(COMPOSITE_MIP)
            acc = max(acc, s);
  #else
            acc = min(acc, s);
  #endif
            samples += 1.0;
            k += 1;
        }
        state.xy = vec2(acc, total);
#endif
    }
#ifdef BRICKED
    frag_color = state;  // raycast_resolve.frag finishes it
#else
  #include "common/resolve.glsl"
#endif
#ifdef COUNT_SAMPLES
    frag_samples = vec2(samples, jumps);
#endif
}
