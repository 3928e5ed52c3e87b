// Projections: COMPOSITE_AVERAGE, COMPOSITE_MIP, COMPOSITE_MINIP (raycast.frag's mode parts; the
// interface is described there).  State: (the running sum of value x length, or the maximum, or
// the minimum; the length summed; REFINE_EXTREMUM: the refined extremum), classified in the resolve.
// REFINE_EXTREMUM (MIP, MinIP; the number of steps): after the loop, safeguarded parabolic steps around
// the extreme sample find the field's extremum between the samples (refine_extremum), as
// dvr_gl.reference.discrete.refine_extremum does; the extreme sample itself still decides what is skipped.

float value;   // the running sum, maximum or minimum
float total;   // average: the length summed

#if defined(COMPOSITE_MIP)
const vec4 EMPTY_STATE = vec4(-3.0e38, 0.0, -3.0e38, 0.0);
#define SIGN 1.0
#elif defined(COMPOSITE_MINIP)
const vec4 EMPTY_STATE = vec4(3.0e38, 0.0, 3.0e38, 0.0);
#define SIGN (-1.0)
#else
const vec4 EMPTY_STATE = vec4(0.0);
#endif

#if defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
float refined;    // the refined extremum (the previous pass's, until this pass raises the extremum)
int extreme_k;    // the segment of the extreme sample, where this pass found it (else -1)
const float GOLDEN = 0.3819660112501051;  // the golden section's smaller part

// SIGN times the field at parameter t of the ray.
float signed_value_at(float t) {
    return SIGN * sample_scalar(o + t * d);
}

// The largest of SIGN times the field found by REFINE_EXTREMUM safeguarded parabolic steps from the
// bracket (m - u_sample_distance, m, m + u_sample_distance) clamped to [t0, t1], m the extreme sample's
// parameter and fm its signed value: each step probes the vertex of the parabola through the bracket's
// points, or the golden-section point of its longer side where that parabola has no maximum inside, and
// keeps the best point in the middle.
float refine_extremum(float m, float fm) {
    float a = max(m - u_sample_distance, t0);
    float b = min(m + u_sample_distance, t1);
    float fa = signed_value_at(a);
    float fb = signed_value_at(b);
    for (int i = 0; i < REFINE_EXTREMUM; i++) {
        float q = (m - a) * (fm - fb);
        float r = (m - b) * (fm - fa);
        float den = 2.0 * (q - r);
        float u = den > 0.0 ? m - ((m - a) * q - (m - b) * r) / den : m;
        if (!(u > a && u < b && u != m)) u = m - a > b - m ? m - GOLDEN * (m - a) : m + GOLDEN * (b - m);
        float fu = signed_value_at(u);
        if (fu > fm) {
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
    }
    return max(fm, max(fa, fb));
}
#endif

bool mode_init(vec4 state) {
    value = state.x;
    total = state.y;
#if defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    refined = state.z;
    extreme_k = -1;
#endif
    return false;
}

bool mode_sample(int k, float start, float len, float t, vec3 p) {
    float s = sample_scalar(p);
#if defined(COMPOSITE_AVERAGE)
    value += s * len;
    total += len;
#elif defined(COMPOSITE_MIP)
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
    return false;
}

void mode_gap() {
}

void mode_run(int k) {
}

// Blocks that cannot raise the maximum (lower the minimum); a block rechecked later may pass:
// the bound moved.  (An average takes every sample: never accelerated.)
bool mode_skippable(vec4 block) {
#if defined(COMPOSITE_MIP)
    return block.y <= value;
#else
    return block.x >= value;
#endif
}

// Runs: the key is the least block maximum (MinIP: the largest minimum) around; above the maximum
// so far (below the minimum), no block there can be skipped yet.
bool mode_dense(float key) {
#if defined(COMPOSITE_MIP)
    return key > value;
#else
    return key < value;
#endif
}

bool mode_jump(vec4 block, inout int m) {
    return false;
}

vec4 mode_finish(vec4 state) {
#if defined(REFINE_EXTREMUM) && !defined(COMPOSITE_AVERAGE)
    if (extreme_k >= 0) refined = SIGN * refine_extremum(sample_t(extreme_k), SIGN * value);
    return vec4(value, total, refined, state.w);
#else
    return vec4(value, total, state.zw);
#endif
}
