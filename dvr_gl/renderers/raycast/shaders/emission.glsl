// Emission-absorption, front to back (raycast.frag's mode parts; the interface is described there).
// State: (colour reaching the eye, optical depth), the opacity taken in the resolve.
// XRAY (the radiograph): nothing attenuated: the state is the sums of sigma c l and sigma l, and the
// resolve gives alpha 1 - exp(-tau) and colour alpha times their ratio (dvr_gl.transfer_function.xray_rgba).

vec3 colour;   // the light of the samples so far that reaches the eye
float depth;   // their optical depth: the transmittance to the next sample is exp(-depth)
#ifdef CLASSIFY_PREINTEGRATED
SegmentValue front;  // the front value of segment k is the back value of segment k - 1
bool front_known;
#endif

const vec4 EMPTY_STATE = vec4(0.0);

#ifdef DEPTH
const float HALF_OPACITY_DEPTH = 0.69314718;  // ln 2: the optical depth of opacity one half
// Before a stretch from `start` of optical depth `tau` at extinction `sigma` is added: where in it the
// optical depth reaches ln 2, if it does (linear within: one extinction per segment, as the reference).
void note_half_opacity(float start, float tau, float sigma) {
    if (depth_t < 0.0 && tau > 0.0 && depth < HALF_OPACITY_DEPTH && depth + tau >= HALF_OPACITY_DEPTH)
        depth_t = start + (HALF_OPACITY_DEPTH - depth) / sigma;
}
#endif

bool terminated() {
#ifdef EARLY_TERMINATION
    return depth >= u_ert_depth;
#else
    return false;
#endif
}

bool mode_init(vec4 state) {
    colour = state.rgb;
    depth = state.a;
#ifdef CLASSIFY_PREINTEGRATED
#ifndef FIELDS
    front = 0.0;
#endif
    front_known = false;
#endif
    return terminated();  // BRICKED: in an earlier pass
}

bool mode_sample(int k, float start, float len, float t, vec3 p) {
#ifdef CLASSIFY_PREINTEGRATED
#ifdef BRICKED
    if (!front_known) front = segment_value(o + start * d);
#endif
    SegmentValue back = segment_value(o + (start + len) * d);
    vec4 e = preintegrated_segment(front, back, len, p, d);
#ifdef DEPTH
    note_half_opacity(start, e.a, e.a / len);
#endif
    front = back;
    front_known = true;
    colour += exp(-depth) * e.rgb;
    depth += e.a;
#else
    vec4 cs = classify(p, d);
    float tau = cs.a * len;
#ifdef DEPTH
    note_half_opacity(start, tau, cs.a);
#endif
#ifdef XRAY
    colour += tau * cs.rgb;
#else
    colour += exp(-depth) * opacity_of_depth(tau) * cs.rgb;
#endif
    depth += tau;
#endif
    return terminated();
}

void mode_gap() {
#ifdef CLASSIFY_PREINTEGRATED
    front_known = false;
#endif
}

// Pre-integration: the run's first front value, fetched once per run rather than under a mask at
// every sample (BRICKED keeps the fetch in mode_sample: a brick's gaps fall inside runs).
void mode_run(int k) {
#ifdef CLASSIFY_PREINTEGRATED
    if (!front_known) {
        front = segment_value(o + segment(k).start * d);
        front_known = true;
    }
#endif
}

// Blocks of constant (colour, sigma) (empty ones: sigma = 0); the others have sigma = -1.
bool mode_skippable(vec4 block) {
    return block.a >= 0.0;
}


// m segments of constant (colour, sigma): closed form, as stepping sums, up to where stepping
// would terminate.
bool mode_jump(vec4 block, inout int m) {
    float count = float(m);
    float tau = block.a * u_sample_distance;
#ifdef EARLY_TERMINATION
    if (tau > 0.0) count = min(count, ceil((u_ert_depth - depth) / tau));
#endif
#ifdef DEPTH
    note_half_opacity(segment(jump_from).start, tau * count, block.a);
#endif
#ifdef XRAY
    colour += tau * count * block.rgb;
#else
    colour += exp(-depth) * opacity_of_depth(tau * count) * block.rgb;
#endif
    depth += tau * count;
    m = int(count);
    return terminated();
}

vec4 mode_finish(vec4 state) {
    return vec4(colour, depth);
}
