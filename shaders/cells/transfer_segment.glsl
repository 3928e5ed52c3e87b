// The emission-absorption integral of the exact transfer function along a segment of length
// `len` whose scalar runs linearly from `sf` to `sb` (a ray's piece in a tetrahedron).
//
// The transfer function is its control points (u_tf: row 0 (value, opacity), row 1 (r, g, b));
// colour and the opacity column are linear between them, extinction too in the `extinction`
// model and -log(1 - alpha) / unit_distance of the linear alpha in the `alpha` model.  The
// segment is cut where the scalar crosses a control value, so every part is smooth and no
// feature of the transfer function between the end values is missed; each part is cut further
// so that no step holds an optical depth over one, and each step is integrated by 4-point
// Gauss-Legendre collocation: optical depth at the nodes by the spectral integration matrix
// (u_gauss_s), emission sigma c exp(-tau) weighted at the nodes, exactly as the converged
// reference does in float64.  Steps are composited front to back; the loop ends once the
// optical depth passes 16.2 (transmittance 1e-7: what is left could add at most that), so a
// thick part costs at most about 17 steps past its thin front.
//
// Returns premultiplied (C, alpha), alpha = 1 - exp(-tau).

uniform sampler2D u_tf;      // K x 2 texels
uniform int u_tf_count;      // K
uniform float u_unit_distance;
uniform vec4 u_gauss_x;      // nodes on [0, 1]
uniform vec4 u_gauss_w;      // weights on [0, 1]
uniform mat4 u_gauss_s;      // column j, row i: integral from 0 to x_i of the Lagrange basis l_j

const float ALPHA_MAX = 0.99999994;   // 1 - 2^-24 (dvr_gl.transfer_function.ALPHA_MAX)
const int MAX_STEPS_PER_PART = 4096;
const int MAX_PARTS = 1024;

float tf_value(int k) { return texelFetch(u_tf, ivec2(k, 0), 0).x; }

// Control interval k (k = -1: below the first value, k = K - 1: above the last; both constant):
// its end values and their (r, g, b, opacity column), fetched once per part of a segment.
struct Interval { float va; float vb; vec4 pa; vec4 pb; };

Interval tf_interval_at(int k) {
    int a = clamp(k, 0, u_tf_count - 1), b = clamp(k + 1, 0, u_tf_count - 1);
    vec4 ra = texelFetch(u_tf, ivec2(a, 0), 0), rb = texelFetch(u_tf, ivec2(b, 0), 0);
    return Interval(ra.x, rb.x, vec4(texelFetch(u_tf, ivec2(a, 1), 0).rgb, ra.y),
                    vec4(texelFetch(u_tf, ivec2(b, 1), 0).rgb, rb.y));
}

// (r, g, b, sigma) at scalar s inside an interval
vec4 tf_in(Interval iv, float s) {
    float f = iv.vb > iv.va ? clamp((s - iv.va) / (iv.vb - iv.va), 0.0, 1.0) : 0.0;
    vec4 c = mix(iv.pa, iv.pb, f);
#ifdef ALPHA_MODEL
    float alpha = min(c.a, ALPHA_MAX);
    // -log(1 - alpha) without cancellation for small alpha
    c.a = (alpha < 1e-3 ? alpha * (1.0 + alpha * (0.5 + alpha / 3.0)) : -log(1.0 - alpha)) / u_unit_distance;
#endif
    return c;
}

// the control interval holding s: the largest k with value_k <= s (-1 below the first)
int tf_interval(float s) {
    int lo = -1, hi = u_tf_count - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (tf_value(mid) <= s) lo = mid; else hi = mid - 1;
    }
    return lo;
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

vec4 premultiplied(vec3 colour, float tau) {
    return vec4(colour, tau < 1e-4 ? tau * (1.0 - 0.5 * tau) : 1.0 - exp(-tau));
}

vec4 transfer_segment(float sf, float sb, float len) {
    int k = tf_interval(sf);
    // The common case, a piece inside one control interval holding an optical depth of at most one:
    // one step, no loop (the same arithmetic as the loop below takes for it).
    Interval first = tf_interval_at(k);
    bool inside = (k < 0 || sb >= first.va) && (k >= u_tf_count - 1 || sb < first.vb);
    if (inside) {
        float sigma_max = max(tf_in(first, sf).a, tf_in(first, sb).a);
        if (len * sigma_max <= 1.0) {
            vec4 step = gauss_step(first, sf, sb, len);
            return premultiplied(step.rgb, step.a);
        }
    }
    vec3 colour = vec3(0.0);
    float tau = 0.0;
    int dir = sb > sf ? 1 : (sb < sf ? -1 : 0);
    float u = 0.0;
    for (int part = 0; part < MAX_PARTS && u < 1.0 && tau < 16.2; ++part) {
        // where this control interval ends along the segment
        float u1 = 1.0;
        if (dir > 0 && k + 1 <= u_tf_count - 1) u1 = clamp((tf_value(k + 1) - sf) / (sb - sf), u, 1.0);
        if (dir < 0 && k >= 0) u1 = clamp((tf_value(k) - sf) / (sb - sf), u, 1.0);
        float part_len = (u1 - u) * len;
        Interval iv = tf_interval_at(k);
        float sigma_max = max(tf_in(iv, mix(sf, sb, u)).a, tf_in(iv, mix(sf, sb, u1)).a);  // monotone inside
        int steps = clamp(int(ceil(part_len * sigma_max)), 1, MAX_STEPS_PER_PART);
        float h = part_len / float(steps);
        for (int j = 0; j < steps && tau < 16.2; ++j) {
            float ua = u + (u1 - u) * float(j) / float(steps), ub = u + (u1 - u) * float(j + 1) / float(steps);
            vec4 step = gauss_step(iv, mix(sf, sb, ua), mix(sf, sb, ub), h);
            colour += exp(-tau) * step.rgb;
            tau += step.a;
        }
        u = u1;
        k += dir;
        if (dir == 0) break;
    }
    return premultiplied(colour, tau);
}
