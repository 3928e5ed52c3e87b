#version 430
// Projected tetrahedra, Shirley and Tuchman's classic variant (SHIRLEY_TUCHMAN, pt.geom): the
// colour and optical depth evaluated at the footprint's vertices (the thick vertex's from the exact
// integral along its ray, the silhouette's of zero thickness), interpolated across the 3 or 4
// triangles, here turned into premultiplied (C alpha, alpha) with alpha = 1 - exp(-tau) (Stein,
// Becker and Max's exponential, not an interpolated opacity), composited by the over operator.
noperspective in vec4 g_st;  // colour, optical depth
flat in float g_tau_max;     // the thick vertex's optical depth

out vec4 frag;

void main() {
    // Clamped to the vertices' range: a sliver of a triangle (the thick vertex a hair from an edge)
    // has attribute slopes so steep that a pixel centre a rounding outside it extrapolates far out
    // (seen on the oxygen post from above: 11 of 16,384 pixels at up to 7.8).
    float tau = clamp(g_st.a, 0.0, g_tau_max);
    float alpha = tau < 1e-3 ? tau * (1.0 - 0.5 * tau) : 1.0 - exp(-tau);  // no cancellation when thin
    frag = vec4(clamp(g_st.rgb, 0.0, 1.0) * alpha, alpha);
}
