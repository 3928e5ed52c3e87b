// Emission-absorption, back to front: the over operator from the last segment to the first
// (raycast.frag's mode parts; the loop walks k downward).  State: the image so far, associated colour.

vec4 acc;   // the segments behind the next one, composited
#ifdef CLASSIFY_PREINTEGRATED
SegmentValue back;  // the back value of segment k is the front value of segment k + 1
bool back_known;
#endif

const vec4 EMPTY_STATE = vec4(0.0);

bool mode_init(vec4 state) {
    acc = state;
#ifdef CLASSIFY_PREINTEGRATED
#ifndef FIELDS
    back = 0.0;
#endif
    back_known = false;
#endif
    return false;
}

bool mode_sample(int k, float start, float len, float t, vec3 p) {
#ifdef CLASSIFY_PREINTEGRATED
#ifdef BRICKED
    if (!back_known) back = segment_value(o + (start + len) * d);
#endif
    SegmentValue front = segment_value(o + start * d);
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
    return false;
}

void mode_gap() {
#ifdef CLASSIFY_PREINTEGRATED
    back_known = false;
#endif
}

// Pre-integration: the run's first back value (the end of segment k), once per run.
void mode_run(int k) {
#ifdef CLASSIFY_PREINTEGRATED
    if (!back_known) {
        Segment s = segment(k);
        back = segment_value(o + (s.start + s.len) * d);
        back_known = true;
    }
#endif
}

bool mode_skippable(vec4 block) {
    return block.a >= 0.0;  // constant (colour, sigma), as for front to back
}


// m segments of constant (colour, sigma) as one.
bool mode_jump(vec4 block, inout int m) {
    float alpha = opacity_of_depth(block.a * u_sample_distance * float(m));
    acc = vec4(block.rgb * alpha, alpha) + (1.0 - alpha) * acc;
    return false;
}

vec4 mode_finish(vec4 state) {
    return acc;
}
