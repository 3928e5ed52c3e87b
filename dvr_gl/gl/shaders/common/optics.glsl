// Emission-absorption optics in float32, in stable forms.

// Opacity 1 - exp(-tau) of optical depth tau: a series where 1 - exp(-tau) cancels.
float opacity_of_depth(float tau) {
    if (tau < 0.01)
        return tau * (1.0 - tau * 0.5 * (1.0 - tau / 3.0 * (1.0 - tau * 0.25)));
    return 1.0 - exp(-tau);
}
