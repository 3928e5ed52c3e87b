// Pixel addressing shared by every full-screen pass.

// Centre of this fragment's pixel in window coordinates (x right, y up, pixel units).
vec2 pixel_centre() {
    return gl_FragCoord.xy;
}
