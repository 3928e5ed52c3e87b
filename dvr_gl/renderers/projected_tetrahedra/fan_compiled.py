"""Shirley and Tuchman's fan built on the host, compiled with numba (the optional extra ``numba``):
the same footprint, thick vertex and exact integral along the thick piece as ``shaders/pt.geom``'s
``SHIRLEY_TUCHMAN`` path, in float64, written into a vertex buffer in visibility order, so the
frame needs no geometry shader (llvmpipe runs that on one thread).

Imported only through :func:`.fan.compiled`, which returns ``None`` where numba is not installed
(the renderer then draws the fan in ``pt.geom``).  Every function is ``njit(cache=True)``.

Conventions: points relative to the mesh's centre (world units); pixels in GL window coordinates
(x right, y up, the image's lower left corner at 0); a cell's scalar is ``g . p + c``; the transfer
function's rows are ``(value, r, g, b, opacity column)``; optical depth is dimensionless.
"""

from __future__ import annotations

import numba
import numpy as np

#: Floats a fan vertex holds: pixel x, y; colour r, g, b; optical depth; the thick vertex's optical
#: depth (``pt_st.frag``'s ``g_st`` and ``g_tau_max``).
VERTEX_FLOATS = 7
#: Vertices a cell writes: the thick vertex, then the silhouette's corners counter-clockwise (a
#: triangle's first corner repeated as its fourth); indices a cell draws: four triangles around the
#: thick vertex (a triangle's fourth has no area).
CELL_VERTICES, CELL_INDICES = 5, 12
MAX_STEPS = 8192  # as transfer_segment.glsl
TAU_END = 16.2    # the integral stops past this optical depth (transmittance 1e-7), as transfer_segment.glsl


@numba.njit(cache=True, nogil=True)
def project(points, view_projection, width, height):
    """``(P, 3)``: each point's pixel x and y and its clip w (as ``pt.geom`` projects)."""
    out = np.empty((len(points), 3))
    m = view_projection
    for i in range(len(points)):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        cx = m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]
        cy = m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]
        cw = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
        out[i, 0] = (cx / cw * 0.5 + 0.5) * width
        out[i, 1] = (cy / cw * 0.5 + 0.5) * height
        out[i, 2] = cw
    return out


@numba.njit(cache=True)
def _orient(q, a, b, c):
    """Twice the signed area of the projected triangle a b c (counter-clockwise positive)."""
    return (q[b, 0] - q[a, 0]) * (q[c, 1] - q[a, 1]) - (q[b, 1] - q[a, 1]) * (q[c, 0] - q[a, 0])


@numba.njit(cache=True)
def _inside(q, p, a, b, c):
    """Whether projected point p lies in the triangle a b c, either orientation."""
    u, v, w = _orient(q, a, b, p), _orient(q, b, c, p), _orient(q, c, a, p)
    return (u >= 0.0 and v >= 0.0 and w >= 0.0) or (u <= 0.0 and v <= 0.0 and w <= 0.0)


@numba.njit(cache=True)
def _silhouette(q, ids):
    """``(h0, h1, h2, h3, inner, area)``: the projected cell's hull counter-clockwise as point indices
    (a triangle repeats h2 as h3), the point projecting inside the other three (-1: a quadrilateral)
    and twice the hull's area (0: no area).  The tests in ``pt.geom``'s order."""
    a, b, c, d = ids[0], ids[1], ids[2], ids[3]
    h0, h1, h2, h3, inner = a, b, c, d, -1
    if _inside(q, d, a, b, c):
        inner = d
    elif _inside(q, c, a, b, d):
        h2, inner = d, c
    elif _inside(q, b, a, c, d):
        h1, h2, inner = c, d, b
    elif _inside(q, a, b, c, d):
        h0, h1, h2, inner = b, c, d, a
    elif _orient(q, a, b, c) * _orient(q, a, b, d) < 0.0:  # diagonal a b
        h1, h2 = c, b
    elif _orient(q, a, c, b) * _orient(q, a, c, d) >= 0.0:  # diagonal a d
        h2, h3 = d, c
    if inner >= 0:
        h3 = h2
    area = _orient(q, h0, h1, h2) + (_orient(q, h0, h2, h3) if inner < 0 else 0.0)
    if area < 0.0:  # clockwise: reverse
        if inner < 0:
            h1, h3 = h3, h1
        else:
            h1, h2 = h2, h1
            h3 = h2
    return h0, h1, h2, h3, inner, abs(area)


@numba.njit(cache=True)
def _tf_at(tf, k, s, alpha_model, unit_distance):
    """``(r, g, b, sigma)`` at scalar ``s`` in control interval ``k`` (-1: below the first value),
    colour and opacity column linear inside it, clamped at its ends; sigma per world unit."""
    n = tf.shape[0]
    a, b = min(max(k, 0), n - 1), min(max(k + 1, 0), n - 1)
    f = 0.0
    if tf[b, 0] > tf[a, 0]:
        f = min(max((s - tf[a, 0]) / (tf[b, 0] - tf[a, 0]), 0.0), 1.0)
    r = tf[a, 1] + (tf[b, 1] - tf[a, 1]) * f
    g = tf[a, 2] + (tf[b, 2] - tf[a, 2]) * f
    bl = tf[a, 3] + (tf[b, 3] - tf[a, 3]) * f
    column = tf[a, 4] + (tf[b, 4] - tf[a, 4]) * f
    if alpha_model:
        column = -np.log1p(-min(column, 1.0 - 2.0 ** -24)) / unit_distance
    return r, g, bl, column


@numba.njit(cache=True)
def _interval(tf, s):
    """The largest k with control value k at most ``s`` (-1 below the first)."""
    return np.searchsorted(tf[:, 0], s, side="right") - 1


@numba.njit(cache=True)
def transfer_segment(sf, sb, length, tf, sigma_max, alpha_model, unit_distance, gx, gw, gs):
    """``(r, g, b, tau)``: the emission-absorption integral along a segment of ``length`` world units
    whose scalar runs linearly from ``sf`` (front) to ``sb``: premultiplied colour and optical depth,
    as ``transfer_segment.glsl`` computes it (cut at control values, steps of optical depth at most
    one by ``sigma_max``, 4-point Gauss-Legendre with nodes ``gx``, weights ``gw`` and spectral
    integration matrix ``gs`` on [0, 1]), in float64."""
    n = tf.shape[0]
    direction = 1 if sb > sf else (-1 if sb < sf else 0)
    k = _interval(tf, sf)
    cr = cg = cb = 0.0
    tau, transmit, u = 0.0, 1.0, 0.0
    for _ in range(MAX_STEPS):
        if not (u < 1.0 and tau < TAU_END):
            break
        a, b = min(max(k, 0), n - 1), min(max(k + 1, 0), n - 1)
        u1 = 1.0
        if (direction > 0 and k + 1 <= n - 1) or (direction < 0 and k >= 0):
            end = tf[b, 0] if direction > 0 else tf[a, 0]
            u1 = min(max((end - sf) / (sb - sf), u), 1.0)
        steps = int(min(max(np.ceil((u1 - u) * length * sigma_max[k + 1]), 1.0), MAX_STEPS))
        ub = u1 if steps == 1 else u + (u1 - u) / steps
        if not ub > u:
            ub = u1
        sa, se, h = sf + (sb - sf) * u, sf + (sb - sf) * ub, (ub - u) * length
        r0, g0, b0, e0 = _tf_at(tf, k, sa + (se - sa) * gx[0], alpha_model, unit_distance)
        r1, g1, b1, e1 = _tf_at(tf, k, sa + (se - sa) * gx[1], alpha_model, unit_distance)
        r2, g2, b2, e2 = _tf_at(tf, k, sa + (se - sa) * gx[2], alpha_model, unit_distance)
        r3, g3, b3, e3 = _tf_at(tf, k, sa + (se - sa) * gx[3], alpha_model, unit_distance)
        step_tau = h * (gw[0] * e0 + gw[1] * e1 + gw[2] * e2 + gw[3] * e3)
        w0 = gw[0] * e0 * np.exp(-h * (gs[0, 0] * e0 + gs[0, 1] * e1 + gs[0, 2] * e2 + gs[0, 3] * e3))
        w1 = gw[1] * e1 * np.exp(-h * (gs[1, 0] * e0 + gs[1, 1] * e1 + gs[1, 2] * e2 + gs[1, 3] * e3))
        w2 = gw[2] * e2 * np.exp(-h * (gs[2, 0] * e0 + gs[2, 1] * e1 + gs[2, 2] * e2 + gs[2, 3] * e3))
        w3 = gw[3] * e3 * np.exp(-h * (gs[3, 0] * e0 + gs[3, 1] * e1 + gs[3, 2] * e2 + gs[3, 3] * e3))
        scale = transmit * h  # the step's emission attenuated by what lies in front
        cr += scale * (w0 * r0 + w1 * r1 + w2 * r2 + w3 * r3)
        cg += scale * (w0 * g0 + w1 * g1 + w2 * g2 + w3 * g3)
        cb += scale * (w0 * b0 + w1 * b1 + w2 * b2 + w3 * b3)
        transmit *= np.exp(-step_tau)
        tau += step_tau
        if ub >= u1:
            k += direction
        u = ub
    return cr, cg, cb, tau


@numba.njit(cache=True)
def _under(p, q, a, b, t):
    """The point of segment a b (point indices) on the ray through screen point a + t (b - a),
    perspective-corrected by the clip w's ``q[:, 2]``."""
    wa, wb = q[a, 2], q[b, 2]
    den = (1.0 - t) * wb + t * wa
    s = t * wa / den if den != 0.0 else t
    return (p[a, 0] + (p[b, 0] - p[a, 0]) * s, p[a, 1] + (p[b, 1] - p[a, 1]) * s,
            p[a, 2] + (p[b, 2] - p[a, 2]) * s)


@numba.njit(cache=True)
def _ray(x, y, z, eye, forward, perspective):
    """The unit direction of the view ray through (x, y, z)."""
    if not perspective:
        return forward[0], forward[1], forward[2]
    dx, dy, dz = x - eye[0], y - eye[1], z - eye[2]
    norm = np.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / norm, dy / norm, dz / norm


@numba.njit(cache=True)
def _thick_piece(p, q, h0, h1, h2, h3, inner, eye, forward, perspective):
    """``(tx, ty, front, back)``: the thick vertex (pixels) and the ends of the cell's thickest piece
    along its ray (3-tuples), front first.  A triangle: the inner point and where its ray meets the
    plane of the other three; a quadrilateral: where the diagonals h0 h2 and h1 h3 cross on screen,
    the points of those two edges under it."""
    if inner < 0:
        ex, ey = q[h2, 0] - q[h0, 0], q[h2, 1] - q[h0, 1]
        fx, fy = q[h3, 0] - q[h1, 0], q[h3, 1] - q[h1, 1]
        gx, gy = q[h1, 0] - q[h0, 0], q[h1, 1] - q[h0, 1]
        den = ex * fy - ey * fx
        t = min(max((gx * fy - gy * fx) / den, 0.0), 1.0) if den != 0.0 else 0.5
        u = min(max((gx * ey - gy * ex) / den, 0.0), 1.0) if den != 0.0 else 0.5
        tx, ty = q[h0, 0] + ex * t, q[h0, 1] + ey * t
        x0 = _under(p, q, h0, h2, t)
        x1 = _under(p, q, h1, h3, u)
    else:
        tx, ty = q[inner, 0], q[inner, 1]
        x0 = (p[inner, 0], p[inner, 1], p[inner, 2])
        ax, ay, az = p[h1, 0] - p[h0, 0], p[h1, 1] - p[h0, 1], p[h1, 2] - p[h0, 2]
        bx, by, bz = p[h2, 0] - p[h0, 0], p[h2, 1] - p[h0, 1], p[h2, 2] - p[h0, 2]
        nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx  # the other three's plane
        dx, dy, dz = _ray(x0[0], x0[1], x0[2], eye, forward, perspective)
        nd = nx * dx + ny * dy + nz * dz
        along = 0.0
        if nd != 0.0:
            along = (nx * (p[h0, 0] - x0[0]) + ny * (p[h0, 1] - x0[1]) + nz * (p[h0, 2] - x0[2])) / nd
        x1 = (x0[0] + along * dx, x0[1] + along * dy, x0[2] + along * dz)
    dx, dy, dz = _ray(x0[0], x0[1], x0[2], eye, forward, perspective)
    if (x1[0] - x0[0]) * dx + (x1[1] - x0[1]) * dy + (x1[2] - x0[2]) * dz < 0.0:
        return tx, ty, x1, x0
    return tx, ty, x0, x1


@numba.njit(cache=True)
def _put(out, row, x, y, r, g, b, tau, tau_max):
    out[row, 0], out[row, 1], out[row, 2], out[row, 3] = x, y, r, g
    out[row, 4], out[row, 5], out[row, 6] = b, tau, tau_max


@numba.njit(cache=True, nogil=True)
def fan(drawn, tets, points, projected, gradients, offsets, eye, forward, perspective, tf, sigma_max,
        alpha_model, unit_distance, gx, gw, gs, out):
    """Write the fan of every cell ``c`` with ``drawn[c]`` into ``out[5 c:5 c + 5]`` (``out``: ``(5 M, 7)``
    float32; the other cells' rows are left as they are): :data:`CELL_VERTICES` rows of
    :data:`VERTEX_FLOATS` (pixel x, y; colour; optical depth; the thick vertex's optical depth).  The
    thick vertex carries the colour and optical depth of the exact integral along the thick piece
    (colour the integral's over its opacity, or the transfer function's at the piece's middle where it
    has none), the silhouette's corners zero optical depth and the transfer function's colour at their
    scalar.  A cell with no projected area writes five equal points (nothing drawn).  ``projected``:
    :func:`project`'s; ``eye`` (perspective) or ``forward`` (orthographic) give the view rays; ``gx``,
    ``gw``, ``gs``: the Gauss-Legendre rule on [0, 1] (:func:`transfer_segment`).  In cell order (the
    visibility order only picks the indices, :func:`indices`), without the GIL: the renderer builds it
    while the order is computed."""
    for c in range(len(tets)):
        if not drawn[c]:
            continue
        h0, h1, h2, h3, inner, area = _silhouette(projected, tets[c])
        row = CELL_VERTICES * c
        if not area > 0.0:
            for m in range(CELL_VERTICES):
                _put(out, row + m, projected[h0, 0], projected[h0, 1], 0.0, 0.0, 0.0, 0.0, 0.0)
            continue
        tx, ty, x0, x1 = _thick_piece(points, projected, h0, h1, h2, h3, inner, eye, forward, perspective)
        g0, g1, g2, offset = gradients[c, 0], gradients[c, 1], gradients[c, 2], offsets[c]
        s_front = g0 * x0[0] + g1 * x0[1] + g2 * x0[2] + offset
        s_back = g0 * x1[0] + g1 * x1[1] + g2 * x1[2] + offset
        length = np.sqrt((x1[0] - x0[0]) ** 2 + (x1[1] - x0[1]) ** 2 + (x1[2] - x0[2]) ** 2)
        r = g = b = tau = 0.0
        if length > 0.0:
            r, g, b, tau = transfer_segment(s_front, s_back, length, tf, sigma_max, alpha_model, unit_distance,
                                            gx, gw, gs)
        alpha = -np.expm1(-tau)
        if alpha > 0.0:
            r, g, b = r / alpha, g / alpha, b / alpha
        else:
            s = 0.5 * (s_front + s_back)
            r, g, b, _ = _tf_at(tf, _interval(tf, s), s, alpha_model, unit_distance)
        _put(out, row, tx, ty, r, g, b, tau, tau)
        for m in range(4):  # the corners; a triangle's first again as its fourth
            v = h0 if m == 0 else (h1 if m == 1 else (h2 if m == 2 else (h3 if inner < 0 else h0)))
            s = g0 * points[v, 0] + g1 * points[v, 1] + g2 * points[v, 2] + offset
            cr, cg, cb, _ = _tf_at(tf, _interval(tf, s), s, alpha_model, unit_distance)
            _put(out, row + 1 + m, projected[v, 0], projected[v, 1], cr, cg, cb, 0.0, tau)


@numba.njit(cache=True, nogil=True)
def indices(order, out):
    """``out[:12 len(order)]``: the triangles of ``order``'s cells' fans, in that order (uint32 vertex
    indices into :func:`fan`'s rows: thick h0 h1, thick h1 h2, thick h2 h3, thick h3 h0)."""
    for i in range(len(order)):
        base = CELL_VERTICES * order[i]
        j = CELL_INDICES * i
        for t in range(4):
            out[j + 3 * t] = base
            out[j + 3 * t + 1] = base + 1 + t
            out[j + 3 * t + 2] = base + 1 + (t + 1) % 4
