#version 430
// Projected tetrahedra, Shirley and Tuchman's classic variant (SHIRLEY_TUCHMAN, pt.geom): the
// colour and optical depth evaluated at the footprint's vertices (the thick vertex's from the exact
// integral along its ray, the silhouette's of zero thickness), interpolated across the 3 or 4
// triangles, here turned into premultiplied (C alpha, alpha) with alpha = 1 - exp(-tau) (Stein,
// Becker and Max's exponential, not an interpolated opacity), composited by the over operator.
noperspective in vec4 g_st;  // colour, optical depth

out vec4 frag;

void main() {
    float tau = g_st.a;
    float alpha = tau < 1e-3 ? tau * (1.0 - 0.5 * tau) : 1.0 - exp(-tau);  // no cancellation when thin
    frag = vec4(g_st.rgb * alpha, alpha);
}
