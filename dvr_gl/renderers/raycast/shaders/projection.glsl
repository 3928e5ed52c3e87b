// Projections: COMPOSITE_AVERAGE, COMPOSITE_MIP, COMPOSITE_MINIP (raycast.frag's mode parts; the
// interface is described there).  State: (the running sum of value x length, or the maximum, or
// the minimum; the length summed; REFINE_EXTREMUM: the refined extremum), classified in the resolve.
// REFINE_EXTREMUM (MIP, MinIP; the number of steps): after the loop, safeguarded parabolic steps around
// the extreme sample find the field's extremum between the samples (refine_extremum), as
// dvr_gl.reference.discrete.refine_extremum does; the extreme sample itself still decides what is skipped.
// SECOND_BRACKET (with REFINE_EXTREMUM): also refines around the second candidate, the best peak of the
// samples other than the extreme one and not next to it (track_second; dvr_gl.reference.discrete.
// SecondCandidates), and keeps the better of the two.  State then: (the extremum, the second candidate, the
// best refined so far, the extreme sample's segment); each pass refines the candidates it found, so across
// passes (bricks, windows) the state keeps the best of every pass's refinements: never worse than one pass's.
// The second candidate bounds what is skipped (a block at or below it can change neither candidate).
// MIP and MinIP read the field through value_at(t): with the hardware's linear filter, an affine map from the
// ray parameter to the texture coordinate set once a pass (mode_init), one multiply-add per axis a fetch.

float value;   // the running sum, maximum or minimum
float total;   // average: the length summed

#if defined(COMPOSITE_MIP)
const vec4 EMPTY_STATE = vec4(-3.0e38, -3.0e38, -3.0e38, 0.0);
#define SIGN 1.0
#elif defined(COMPOSITE_MINIP)
const vec4 EMPTY_STATE = vec4(3.0e38, 3.0e38, 3.0e38, 0.0);
#define SIGN (-1.0)
#else
const vec4 EMPTY_STATE = vec4(0.0);
#endif

#if !defined(COMPOSITE_AVERAGE)
#if defined(FILTER_LINEAR) && !defined(FILTER_IN_SHADER)
#define AFFINE_FETCH
// The texture coordinate at parameter t is texcoord_entry + (t - t0) * texcoord_step: sample_scalar's position,
// voxel coordinate, clamp and division, hoisted out of the loop (brain-mip's frame 0.74x; docs/peers.md, "A
// cheaper MIP loop").  It starts where the ray enters the box, not at the ray's origin, whose coordinate may be
// large (a small brick's, seen from afar) and cancel.  The clamp to the outer samples is the texture's
// clamp-to-edge, which gives a linear fetch the same value there.  Rounding differs from sample_scalar's by a few
// ulps of the coordinate, which flips llvmpipe's 8-bit filtered value by one step in about 1e-3 of the fetches.
vec3 texcoord_entry, texcoord_step;
#endif

// Texture coordinates for value_at (AFFINE_FETCH); the pass's volume (a brick's, under BRICKED).
void set_up_fetch() {
#ifdef AFFINE_FETCH
    vec3 per_texel = 1.0 / vec3(u_dims);
    texcoord_entry = (voxel_coord(o + t0 * d) + 0.5) * per_texel;
    texcoord_step = d * u_world_to_voxel_scale * per_texel;
#endif
}

// The field at parameter t of the ray (data units).
float value_at(float t) {
#ifdef AFFINE_FETCH
    return texture(u_volume, texcoord_entry + (t - t0) * texcoord_step).r * u_value_scale + u_value_offset;
#else
    return sample_scalar(o + t * d);
#endif
}
#endif

#if defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
float refined;    // the refined extremum (the previous pass's, until this pass raises the extremum)
int extreme_k;    // the segment of the extreme sample, where this pass found it (else -1)
const float GOLDEN = 0.3819660112501051;  // the golden section's smaller part

// SIGN times the field at parameter t of the ray.
float signed_value_at(float t) {
    return SIGN * value_at(t);
}

// The largest of SIGN times the field found by REFINE_EXTREMUM safeguarded parabolic steps from each of
// `brackets` brackets (m - u_sample_distance, m, m + u_sample_distance) clamped to [t0, t1], m the candidate's
// parameter (m0, then m1) and fm its signed value: each bracket's ends are fetched, then each step probes the
// vertex of the parabola through the bracket's points, or the golden-section point of its longer side where
// that parabola has no maximum inside, and keeps the best point in the middle.
// One loop with one fetch site for every bracket's ends and steps: llvmpipe inlines the sampling code at each
// call site, and the twelve unrolled copies of two brackets of four steps cost about five loop samples a fetch
// on spindle-mip's slab (the same loop not unrolled: 0.7x the refinement's time; one site: 0.5x).  The trip
// count is kept from being a constant so that the compiler does not unroll it again (docs/peers.md, "A cheaper
// refinement").
float refine_extremum(float m0, float fm0, float m1, float fm1, int brackets) {
    const int PER_BRACKET = REFINE_EXTREMUM + 2;  // the two ends, then the steps
    int fetches = brackets * PER_BRACKET + int(u_sample_distance < 0.0);  // not a constant: not unrolled
    float best = -3.0e38;
    float m = m0, fm = fm0, a = t0, b = t1, fa = 0.0, fb = 0.0;
    int j = 0;  // the fetch within the bracket
    for (int i = 0; i < fetches; i++) {
        if (j == 0) {
            if (i > 0) { m = m1; fm = fm1; }
            a = max(m - u_sample_distance, t0);
            b = min(m + u_sample_distance, t1);
        }
        float u = j == 0 ? a : b;
        if (j >= 2) {
            float q = (m - a) * (fm - fb);
            float r = (m - b) * (fm - fa);
            float den = 2.0 * (q - r);
            u = den > 0.0 ? m - ((m - a) * q - (m - b) * r) / den : m;
            if (!(u > a && u < b && u != m)) u = m - a > b - m ? m - GOLDEN * (m - a) : m + GOLDEN * (b - m);
        }
        float fu = signed_value_at(u);
        if (j == 0) {
            fa = fu;
        } else if (j == 1) {
            fb = fu;
        } else if (fu > fm) {
            if (u < m) { b = m; fb = fm; } else { a = m; fa = fm; }
            m = u;
            fm = fu;
        } else if (u < m) {
            a = u;
            fa = fu;
        } else {
            b = u;
            fb = fu;
        }
        if (++j == PER_BRACKET) {
            best = max(best, max(fm, max(fa, fb)));
            j = 0;
        }
    }
    return best;
}
#endif

#if defined(SECOND_BRACKET) && defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
// The second candidate: the best peak of the samples other than the extreme sample and not next to it.  A peak
// is a sample at least as large as the samples beside it (SIGN times each); beside a ray's ends, a gap or a
// jump there is none (a jumped block holds nothing above the second: skipping changes no candidate).  So the
// second bracket goes to a second peak, not to the extreme peak's own shoulder two segments away, which the
// best sample not next to it often was (a broad peak's shoulder outranks a narrower peak elsewhere: the dividing
// cell's chromosomes, docs/peers.md, "A cheaper refinement").  A sample is known to be a peak one sample late.
float second;           // the second candidate (SIGN times it is at most SIGN times value)
int second_k;           // its segment, where this pass found it (else -1)
float peak;             // SIGN times the best peak so far (at the end: the extremum)
int peak_k;             // its segment (this pass's or an earlier one's)
int peak_here;          // the same, where this pass found it (else -1)
float last_s;           // SIGN times the last sample, whose peak is not decided yet
int last_k;             // its segment (-2: none)
bool last_rises;        // it is at least the sample before it (or has none beside it)

// The peak c (SIGN times it) of segment k: the best peak so far, or the best not next to it.
void offer_peak(float c, int k) {
    if (c > peak) {
        second = SIGN * peak;  // the old best is two or more segments back: peaks next to each other are equal
        second_k = peak_here;
        peak = c;
        peak_k = k;
        peak_here = k;
    } else if (c > SIGN * second && k - peak_k >= 2) {
        second = SIGN * c;
        second_k = k;
    }
}

// The last sample has no next one (a gap, the pass's end): a peak where it rises.
void close_last() {
    if (last_k >= 0 && last_rises) offer_peak(last_s, last_k);
    last_k = -2;
}

// Sample s (SIGN times it) of segment k decides whether the last sample is a peak, and waits for its own.
// Strict comparisons: the first sample holding a value wins.
void track_second(int k, float s) {
    bool follows = last_k == k - 1;
    if (last_k >= 0 && last_rises && (!follows || last_s >= s)) offer_peak(last_s, last_k);
    last_rises = !follows || s >= last_s;
    last_s = s;
    last_k = k;
}
#define SKIP_BOUND second
#else
#define SKIP_BOUND value
#endif

bool mode_init(vec4 state) {
    value = state.x;
    total = state.y;
#if !defined(COMPOSITE_AVERAGE)
    set_up_fetch();
#endif
#if defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    refined = state.z;
    extreme_k = -1;
#endif
#if defined(SECOND_BRACKET) && defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    second = state.y;
    second_k = -1;
    peak = SIGN * state.x;
    peak_k = int(state.w);
    peak_here = -1;
    last_k = -2;
    last_rises = true;
#endif
    return false;
}

bool mode_sample(int k, float start, float len, float t, vec3 p) {
#if defined(COMPOSITE_AVERAGE)
    float s = sample_scalar(p);
    value += s * len;
    total += len;
#else
    float s = value_at(t);
#if defined(SECOND_BRACKET) && defined(REFINE_EXTREMUM)
    track_second(k, SIGN * s);
#endif
#if defined(COMPOSITE_MIP)
#ifdef DEPTH
    if (s > value) depth_t = t;  // the first sample holding the maximum
#endif
#ifdef REFINE_EXTREMUM
    if (s > value) extreme_k = k;
#endif
    value = max(value, s);
#else
#ifdef DEPTH
    if (s < value) depth_t = t;
#endif
#ifdef REFINE_EXTREMUM
    if (s < value) extreme_k = k;
#endif
    value = min(value, s);
#endif
#endif
    return false;
}

void mode_gap() {
#if defined(SECOND_BRACKET) && defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    close_last();  // the next sample does not follow the last one
#endif
}

void mode_run(int k) {
}

// Blocks that cannot raise the maximum (lower the minimum); a block rechecked later may pass:
// the bound moved.  (An average takes every sample: never accelerated.)
bool mode_skippable(vec4 block) {
#if defined(COMPOSITE_MIP)
    return block.y <= SKIP_BOUND;
#else
    return block.x >= SKIP_BOUND;
#endif
}

// Runs: the key is the least block maximum (MinIP: the largest minimum) around; above the maximum
// so far (below the minimum), no block there can be skipped yet.
bool mode_dense(float key) {
#if defined(COMPOSITE_MIP)
    return key > SKIP_BOUND;
#else
    return key < SKIP_BOUND;
#endif
}

bool mode_jump(vec4 block, inout int m) {
    return false;
}

vec4 mode_finish(vec4 state) {
#if defined(SECOND_BRACKET) && defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    close_last();
    float best = SIGN * refined;  // every pass's refinements: each a value of the field on the ray
    // the candidates this pass found, the extreme one first: one call, so one inlined copy of the fetch
    bool extreme_here = extreme_k >= 0;
    int brackets = int(extreme_here) + int(second_k >= 0);
    if (brackets > 0) {
        best = max(best, refine_extremum(sample_t(extreme_here ? extreme_k : second_k),
                                         SIGN * (extreme_here ? value : second), sample_t(second_k), SIGN * second,
                                         brackets));
    }
    return vec4(value, second, SIGN * best, float(peak_k));
#elif defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    if (extreme_k >= 0) refined = SIGN * refine_extremum(sample_t(extreme_k), SIGN * value, 0.0, 0.0, 1);
    return vec4(value, total, refined, state.w);
#else
    return vec4(value, total, state.zw);
#endif
}
