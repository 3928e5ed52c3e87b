// Projections: COMPOSITE_AVERAGE, COMPOSITE_MIP, COMPOSITE_MINIP (raycast.frag's mode parts; the
// interface is described there).  State: (the running sum of value x length, or the maximum, or
// the minimum; the length summed), classified in the resolve.

float value;   // the running sum, maximum or minimum
float total;   // average: the length summed

#if defined(COMPOSITE_MIP)
const vec4 EMPTY_STATE = vec4(-3.0e38, 0.0, 0.0, 0.0);
#elif defined(COMPOSITE_MINIP)
const vec4 EMPTY_STATE = vec4(3.0e38, 0.0, 0.0, 0.0);
#else
const vec4 EMPTY_STATE = vec4(0.0);
#endif

bool mode_init(vec4 state) {
    value = state.x;
    total = state.y;
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
    value = max(value, s);
#else
#ifdef DEPTH
    if (s < value) depth_t = t;
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
    return vec4(value, total, state.zw);
}
