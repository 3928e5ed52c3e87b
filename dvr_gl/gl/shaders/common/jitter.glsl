// Per-pixel sample offsets in [0, 1), identical to dvr_gl.rays.jitter_offsets:
// PCG hash (Jarzynski & Olano 2020) of the row-major pixel index (row 0 at the top) plus the
// hashed seed; the top 24 bits, exact in float32.

uniform uint u_jitter_seed;

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float jitter_offset() {
    uint x = uint(gl_FragCoord.x);
    uint row = uint(u_image_size.y) - 1u - uint(gl_FragCoord.y);
    uint h = pcg_hash(x + uint(u_image_size.x) * row + pcg_hash(u_jitter_seed));
    return float(h >> 8u) / 16777216.0;
}
