// The emission-absorption integral of the exact transfer function along a segment of length
// `len` whose scalar runs linearly from `sf` to `sb` (a ray's piece in a tetrahedron).
//
// The transfer function is its TF_COUNT control points, in uniforms (TF_POW2: a power of two above
// TF_COUNT, for the search); colour and the opacity column are linear between them, extinction too
// in the `extinction` model and -log(1 - alpha) / unit_distance of the linear alpha in the `alpha`
// model.  The segment is cut where the scalar crosses a control value, so every part is smooth and
// no feature of the transfer function between the end values is missed; each part is cut further
// so that no step holds an optical depth over one, and each step is integrated by 4-point
// Gauss-Legendre collocation: optical depth at the nodes by the spectral integration matrix
// (u_gauss_s), emission sigma c exp(-tau) weighted at the nodes, exactly as the converged reference
// does in float64.  (Two nodes cost 25 % less and were 20x off on a narrow band of alpha 0.95,
// where -log(1 - alpha) bends sharply: RMS 4.6e-4 against 2.3e-5, tests/test_projected_tetrahedra.py.)
// One loop, one step an iteration, so the common piece (inside one control interval, optically
// thin) is one iteration: llvmpipe runs a branch's code even where no lane takes it, and a fast
// path beside the loop cost a third of the frame.  Steps are composited front to back; the loop
// ends once the optical depth passes 16.2 (transmittance 1e-7: what is left could add at most that).
//
// Returns premultiplied (C, alpha), alpha = 1 - exp(-tau).

uniform vec2 u_tf_value_opacity[TF_COUNT];  // control value, opacity column
uniform vec3 u_tf_rgb[TF_COUNT];
uniform float u_tf_sigma_max[TF_COUNT + 1];  // interval k's largest extinction at k + 1 (k = -1 first)
uniform float u_unit_distance;
uniform vec4 u_gauss_x;      // nodes on [0, 1]
uniform vec4 u_gauss_w;      // weights on [0, 1]
uniform mat4 u_gauss_s;      // column j, row i: integral from 0 to x_i of the Lagrange basis l_j, on [0, 1]

const float ALPHA_MAX = 0.99999994;   // 1 - 2^-24 (dvr_gl.transfer_function.ALPHA_MAX)
const int MAX_STEPS = 8192;

// Control interval k (k = -1: below the first value, k = TF_COUNT - 1: above the last; both
// constant): its end values and their (r, g, b, opacity column).
struct Interval { float va; float vb; vec4 pa; vec4 pb; float inv; };  // inv: 1 / (vb - va), 0 if empty

Interval tf_interval_at(int k) {
    int a = clamp(k, 0, TF_COUNT - 1), b = clamp(k + 1, 0, TF_COUNT - 1);
    vec2 ra = u_tf_value_opacity[a], rb = u_tf_value_opacity[b];
    vec3 ca = u_tf_rgb[a], cb = u_tf_rgb[b];
    return Interval(ra.x, rb.x, vec4(ca, ra.y), vec4(cb, rb.y), rb.x > ra.x ? 1.0 / (rb.x - ra.x) : 0.0);
}

// the control interval holding s: the largest k with value_k <= s (-1 below the first)
int tf_interval(float s) {
    int k = -1;
#if TF_COUNT <= 16
    // counted over every control value: constant indices, so uniform loads, not one gather per lane
    // and step as the binary search needs (on the blunt fin with 5 points, 7 % of the frame)
    for (int i = 0; i < TF_COUNT; ++i) k += int(u_tf_value_opacity[i].x <= s);
#else
    for (int b = TF_POW2 / 2; b >= 1; b /= 2)
        if (k + b < TF_COUNT && u_tf_value_opacity[k + b].x <= s) k += b;
#endif
    return k;
}

float interval_fraction(Interval iv, float s) {
    return clamp((s - iv.va) * iv.inv, 0.0, 1.0);
}

// log(1 - alpha) of the `alpha` model's opacity column, without cancellation for small alpha
float log_transmit(float column) {
    float alpha = min(column, ALPHA_MAX);
    return alpha < 1e-3 ? -alpha * (1.0 + alpha * (0.5 + alpha / 3.0)) : log(1.0 - alpha);
}

// extinction per unit length from the opacity column
float extinction(float column) {
#ifdef ALPHA_MODEL
    return -log_transmit(column) / u_unit_distance;
#else
    return column;
#endif
}

// (r, g, b, sigma) at scalar s inside an interval
vec4 tf_in(Interval iv, float s) {
    vec4 c = mix(iv.pa, iv.pb, interval_fraction(iv, s));
    return vec4(c.rgb, extinction(c.a));
}

// One step of Gauss-Legendre collocation over [sa, sb] (length h) inside interval iv: the step's
// colour (not yet attenuated by what lies in front) and its optical depth.
vec4 gauss_step(Interval iv, float sa, float sb, float h) {
    // written out node by node: llvmpipe keeps a dynamically indexed local array in memory, per lane
    vec4 e0 = tf_in(iv, mix(sa, sb, u_gauss_x.x)), e1 = tf_in(iv, mix(sa, sb, u_gauss_x.y));
    vec4 e2 = tf_in(iv, mix(sa, sb, u_gauss_x.z)), e3 = tf_in(iv, mix(sa, sb, u_gauss_x.w));
    vec4 sig = vec4(e0.a, e1.a, e2.a, e3.a);
    vec4 weight = h * u_gauss_w * sig * exp(-h * (u_gauss_s * sig));  // optical depth to each node
    vec3 colour = weight.x * e0.rgb + weight.y * e1.rgb + weight.z * e2.rgb + weight.w * e3.rgb;
    return vec4(colour, h * dot(u_gauss_w, sig));
}

vec4 transfer_segment(float sf, float sb, float len) {
    int dir = sb > sf ? 1 : (sb < sf ? -1 : 0);
    int k = tf_interval(sf);
    vec3 colour = vec3(0.0);
    float tau = 0.0, transmit = 1.0;
    float u = 0.0;  // where along the segment, 0 to 1
    for (int i = 0; i < MAX_STEPS && u < 1.0 && tau < 16.2; ++i) {
        Interval iv = tf_interval_at(k);
        // where this control interval ends along the segment
        bool bounded = dir > 0 ? k + 1 <= TF_COUNT - 1 : (dir < 0 && k >= 0);
        float u1 = bounded ? clamp(((dir > 0 ? iv.vb : iv.va) - sf) / (sb - sf), u, 1.0) : 1.0;
        // steps of optical depth at most one, by the interval's largest extinction (at one of its
        // ends: the column is linear inside it and the extinction grows with it), from the host
        int steps = clamp(int(ceil((u1 - u) * len * u_tf_sigma_max[k + 1])), 1, MAX_STEPS);
        float ub = steps == 1 ? u1 : u + (u1 - u) / float(steps);
        ub = ub > u ? ub : u1;  // a step too short to move u in float32: the rest of the part at once
        vec4 step = gauss_step(iv, mix(sf, sb, u), mix(sf, sb, ub), (ub - u) * len);
        colour += transmit * step.rgb;
        transmit *= exp(-step.a);
        tau += step.a;
        if (ub >= u1) k += dir;  // on into the next control interval
        u = ub;
    }
    return vec4(colour, tau < 1e-4 ? tau * (1.0 - 0.5 * tau) : 1.0 - transmit);
}
