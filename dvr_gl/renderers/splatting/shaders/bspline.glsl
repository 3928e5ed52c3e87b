// A sample's cubic B-spline kernel B(u) B(v) B(w) (the tensor product, in voxel units: support a cube
// of four voxels) along this pixel's ray, integrated exactly: along a ray each factor is a cubic between
// the places where its coordinate crosses a whole voxel, so the kernel is a polynomial of degree 9 between
// the sorted crossings, which 5-point Gauss-Legendre integrates exactly.  No table: a ray meets the cube
// in up to ten pieces (dvr_gl/renderers/splatting/oracle.py integrates the same pieces in float64).

float bspline(float u) {
    float a = abs(u);
    if (a >= 2.0)
        return 0.0;
    if (a >= 1.0) {
        float b = 2.0 - a;
        return b * b * b / 6.0;
    }
    return 2.0 / 3.0 - a * a + 0.5 * a * a * a;
}

// The kernel centred at `centre` integrated along the ray over [lo, hi] (the ray's parameter); spacing:
// world units per voxel.  As kernel_integral (kernel.glsl), the ray is taken from its point at lo.
float bspline_integral(vec3 o, vec3 d, vec3 centre, vec3 spacing, float lo, float hi) {
    vec3 uo = (o + lo * d - centre) / spacing;
    vec3 ud = d / spacing;
    float enter = 0.0, leave = hi - lo;
    for (int i = 0; i < 3; ++i) {
        if (abs(ud[i]) < 1e-12) {
            if (abs(uo[i]) >= 2.0)
                return 0.0;
            continue;
        }
        float ta = (-2.0 - uo[i]) / ud[i], tb = (2.0 - uo[i]) / ud[i];
        enter = max(enter, min(ta, tb));
        leave = min(leave, max(ta, tb));
    }
    if (leave <= enter)
        return 0.0;
    float cut[11];
    int n = 0;
    cut[n++] = enter;
    for (int i = 0; i < 3; ++i) {
        if (abs(ud[i]) < 1e-12)
            continue;
        for (int k = -1; k <= 1; ++k) {
            float t = (float(k) - uo[i]) / ud[i];
            if (t > enter && t < leave)
                cut[n++] = t;
        }
    }
    cut[n++] = leave;
    for (int i = 1; i < n; ++i) {  // insertion sort of at most 11
        float v = cut[i];
        int j = i - 1;
        while (j >= 0 && cut[j] > v) {
            cut[j + 1] = cut[j];
            --j;
        }
        cut[j + 1] = v;
    }
    const float x[5] = float[5](-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640);
    const float w[5] = float[5](0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665, 0.2369268850561891);
    float total = 0.0;
    for (int p = 0; p + 1 < n; ++p) {
        float half_width = 0.5 * (cut[p + 1] - cut[p]);
        if (half_width <= 0.0)
            continue;
        float mid = 0.5 * (cut[p + 1] + cut[p]);
        float piece = 0.0;
        for (int q = 0; q < 5; ++q) {
            vec3 u = uo + (mid + half_width * x[q]) * ud;
            piece += w[q] * bspline(u.x) * bspline(u.y) * bspline(u.z);
        }
        total += half_width * piece;
    }
    return total;
}
