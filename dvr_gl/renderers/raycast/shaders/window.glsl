// Stage 2 of raycast.frag: the pass window, the segments this pass walks.

#ifdef RAY_BOUNDS
uniform sampler2D u_ray_bounds;  // (first entry, -last exit) of the non-empty blocks, this pixel (world units)

// Narrow `window` to the segments from one before the ray's first entry into a non-empty block to one
// after its last exit (ray_bounds.frag); those left out lie in empty blocks and add exactly nothing.
// The margin of a segment covers the bounds' rounding; no faces crossed: +inf, -(-inf).
ivec2 bound_window(ivec2 window) {
    vec2 bounds = texelFetch(u_ray_bounds, ivec2(gl_FragCoord.xy), 0).xy;
    int k_first = max(window.x, int(clamp(floor((bounds.x - t0) / u_sample_distance) - 1.0, 0.0, float(n))));
    int k_last = min(window.y, int(clamp(ceil((-bounds.y - t0) / u_sample_distance) + 1.0, 0.0, float(n))));
    return ivec2(k_first, k_last);
}
#endif

// This pass's segments [first, last) of the ray set up by set_up_ray() (o, d, t0, n): all n of them,
// narrowed to the brick and the segment window (BRICKED, which also sets the sure interval and may
// find that the ray misses the brick: `hit`) and to the ray bounds (RAY_BOUNDS).
ivec2 pass_window(inout bool hit) {
    ivec2 window = ivec2(0, n);
#ifdef BRICKED
    window = brick_window(hit);
    find_sure_interval();
#endif
#ifdef RAY_BOUNDS
    window = bound_window(window);
#endif
    return window;
}
