// Stage 3 of raycast.frag: the walk along the window's segments.  What every strategy shares (the
// walking direction, one segment's sample, the counts) and the plain strategy, which samples every
// segment; skipping.glsl's strategy jumps empty space as well.

// COUNT_SAMPLES (benchmarks): volume samples, block jumps, block lookups and segments jumped, this
// pixel, over every pass so far.
float samples, jumps, lookups, jumped;
#if defined(BRICKED) && defined(COUNT_SAMPLES)
uniform sampler2D u_counts;     // the counts of the passes before, this pixel
#endif

// Reads the counts the passes before left (BRICKED), or starts them at zero.
void start_counts() {
    samples = 0.0;
    jumps = 0.0;
    lookups = 0.0;
    jumped = 0.0;
#if defined(BRICKED) && defined(COUNT_SAMPLES)
    vec4 counted = texelFetch(u_counts, ivec2(gl_FragCoord.xy), 0);
    samples = counted.x;
    jumps = counted.y;
    lookups = counted.z;
    jumped = counted.w;
#endif
}

// The walking direction along k: upward from the window's first segment, or (BACK_TO_FRONT) downward
// from its last.  A window is [first, last) in segment indices.
#ifdef BACK_TO_FRONT
#define STEP (-1)
int first_segment(ivec2 window) { return window.y - 1; }
bool in_window(int k, ivec2 window) { return k >= window.x; }
#else
#define STEP 1
int first_segment(ivec2 window) { return window.x; }
bool in_window(int k, ivec2 window) { return k < window.y; }
#endif

// Composite segment k, sampled where segment() puts it (BRICKED: where this brick owns the sample;
// another brick's is a gap), and count the sample.  Reads the ray; returns whether the ray is done
// (mode_sample's: early termination, a hit).
bool take_segment(int k) {
    Segment s = segment(k);
    vec3 p = o + s.t * d;
#ifdef BRICKED
    if (!owns_sample(s.t, p)) {
        mode_gap();  // another brick's sample
        return false;
    }
#endif
    samples += 1.0;
    return mode_sample(k, s.start, s.len, s.t, p);
}

// Plain marching: every segment of `window` in the walking direction, as one run, until the ray is
// done (`done`: mode_init's answer).  Reads the ray; the mode keeps the result in its state.
void march_every(ivec2 window, bool done) {
    int k = first_segment(window);
    if (window.x < window.y) mode_run(k);  // one run: every segment
    while (!done && in_window(k, window)) {
        done = take_segment(k);
        k += STEP;
    }
}
