"""Image-aligned post-classified sheets of Gaussian splats on the host, compiled with numba (the optional
extra ``numba``); imported only through :func:`.host.compiled`, which leaves the frame to GL where numba is
not installed.

Both loops compute what ``shaders/splat.frag`` (``kernel_integral``) and ``shaders/sheet.frag`` compute per
fragment, in float64 from the same two tables (the footprint ``F(q)`` and the standard normal's cumulative
``Phi``, linearly interpolated):

* :func:`fill_sheets`: for each splat of a range and each pixel of its screen rectangle still below the
  early-termination threshold, the kernel's integral along the pixel's ray over each slab's part (inside
  the box, from the near plane) of a group of slabs, added to that slab's sheet; and the splat's core flag
  where the part passes within half a voxel's diagonal of its centre (culling, :mod:`.splats`).
* :func:`composite_sheets`: each slab's sheet of the group, front to back: the part's mean classified
  through the transfer-function table (linear interpolation, clamped to its domain), one segment of the
  part's length, composited under the image (premultiplied RGBA).

Coordinates are world units relative to the volume's centre; pixels are row-major from the top.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def _pixel_at_or_after(place, pixels):
    """The first pixel at or after ``place`` (pixel centres at integers; 1e-9 of slack), in ``0 .. pixels``
    (``pixels``: none)."""
    return max(int(math.ceil(min(max(place - 1e-9, -1.0), float(pixels)))), 0)


@numba.njit(cache=True)
def _pixel_at_or_before(place, pixels):
    """The last pixel at or before ``place``, in ``-1 .. pixels - 1`` (``-1``: none)."""
    return int(math.floor(min(max(place + 1e-9, -1.0), pixels - 1.0)))


@numba.njit(cache=True)
def _screen_interval(x, z, a_xx, a_xz, a_zz, perspective, near):
    """The interval of ``x / z`` (perspective) or ``x`` (orthographic) over an ellipsoid whose centre is at
    ``x`` across and ``z`` along the view from the eye, and whose matrix ``A`` (semi-axes' outer products
    summed) has ``a_xx = e_x^T A e_x``, ``a_xz``, ``a_zz`` in the plane of the two directions; ``(-inf, inf)``
    where the ellipsoid reaches the near plane (every pixel).  Perspective: the planes ``x = t z`` through
    the eye tangent to it, ``(x - t z)^2 = a_xx - 2 t a_xz + t^2 a_zz`` (for a sphere of radius ``r``, the
    bounding sphere's tangents)."""
    if not perspective:
        half = math.sqrt(a_xx)
        return x - half, x + half
    if z - math.sqrt(a_zz) <= near:
        return -math.inf, math.inf
    a = z * z - a_zz
    b = x * z - a_xz
    root = math.sqrt(max(b * b - a * (x * x - a_xx), 0.0))
    return (b - root) / a, (b + root) / a


@numba.njit(cache=True)
def splat_schedule(positions, values, core, eye, basis, half, semi_axes, perspective, near, width, height, depth0,
                   slab_width, slabs, reach, group):
    """The splats in the order :func:`fill_sheets` takes them, with their places on the screen and among the
    slabs.

    ``positions``: ``(n, 3)`` centres; ``eye``: the eye, both relative to the volume's centre (world units);
    ``values``, ``core``: the splats' values and core flags (or empty); ``basis``: rows forward, right, up;
    ``half``: the view's half width and height (:meth:`Camera.half_extent`); ``semi_axes``: ``(3,)`` the
    kernel's support's semi-axes along the world axes (radius times spacing, world units); slabs ``k`` span
    view depths ``depth0 + slab_width * [k, k + 1]``, ``slabs`` of them; ``reach``: how far a kernel reaches
    along the view (world units); ``group``: slabs a group.

    Returns the splats' positions, values and core flags sorted by the group of their first slab (a counting
    sort: stable, each group's splats in the lattice's order; read in order, written to a stream per group);
    ``rect`` ``(n, 4)`` the columns and rows ``i0, i1, j0, j1`` (from the top, inclusive; empty where ``i1 <
    i0``) of the pixels whose centres lie in the screen rectangle of the kernel's ellipsoid; ``slab_range``
    ``(n, 2)`` their first and last slab; and ``start`` ``(groups + 1,)``: where the splats whose first slab
    is in group ``g`` begin."""
    n = positions.shape[0]
    first = np.empty(n, np.int32)
    last = np.empty(n, np.int32)
    groups = (slabs + group - 1) // group
    count = np.zeros(groups + 1, np.int64)
    for s in range(n):
        depth = 0.0
        for c in range(3):
            depth += (positions[s, c] - eye[c]) * basis[0, c]
        first[s] = min(max(int(math.floor((depth - reach - depth0) / slab_width)), 0), slabs - 1)
        last[s] = min(max(int(math.floor((depth + reach - depth0) / slab_width)), 0), slabs - 1)
        count[first[s] // group + 1] += 1
    start = np.cumsum(count)
    fill = start[:-1].copy()
    culling = core.shape[0] > 0
    sorted_positions = np.empty((n, 3))
    sorted_values = np.empty(n)
    sorted_core = np.empty(n if culling else 0)
    slab_range = np.empty((n, 2), np.int32)
    for s in range(n):
        o = fill[first[s] // group]
        fill[first[s] // group] += 1
        for c in range(3):
            sorted_positions[o, c] = positions[s, c]
        sorted_values[o] = values[s]
        if culling:
            sorted_core[o] = core[s]
        slab_range[o, 0] = first[s]
        slab_range[o, 1] = last[s]
    # the ellipsoid's matrix A = sum_i semi_axes_i^2 e_i e_i^T in the view's directions
    a_ff = a_rr = a_uu = a_rf = a_uf = 0.0
    for c in range(3):
        e2 = semi_axes[c] * semi_axes[c]
        a_ff += e2 * basis[0, c] * basis[0, c]
        a_rr += e2 * basis[1, c] * basis[1, c]
        a_uu += e2 * basis[2, c] * basis[2, c]
        a_rf += e2 * basis[1, c] * basis[0, c]
        a_uf += e2 * basis[2, c] * basis[0, c]
    rect = np.empty((n, 4), np.int32)
    for o in range(n):
        x = y = z = 0.0
        for c in range(3):
            p = sorted_positions[o, c] - eye[c]
            z += p * basis[0, c]
            x += p * basis[1, c]
            y += p * basis[2, c]
        x0, x1 = _screen_interval(x, z, a_rr, a_rf, a_ff, perspective, near)
        y0, y1 = _screen_interval(y, z, a_uu, a_uf, a_ff, perspective, near)
        # pixel column i has ndc x (i + 0.5) / w * 2 - 1; row j (from the top) ndc y 1 - 2 (j + 0.5) / h
        rect[o, 0] = _pixel_at_or_after((x0 / half[0] + 1.0) * 0.5 * width - 0.5, width)
        rect[o, 1] = _pixel_at_or_before((x1 / half[0] + 1.0) * 0.5 * width - 0.5, width)
        rect[o, 2] = _pixel_at_or_after((1.0 - y1 / half[1]) * 0.5 * height - 0.5, height)
        rect[o, 3] = _pixel_at_or_before((1.0 - y0 / half[1]) * 0.5 * height - 0.5, height)
    return sorted_positions, sorted_values, sorted_core, rect, slab_range, start


@numba.njit(cache=True, parallel=True)
def fill_sheets(first, last, positions, values, core, rect, slab_range, origins, directions, t0, t1, crossings, k0,
                inv_spacing, radius, sigma, footprint, cumulative, alpha, threshold, width, bands, sheet, cores,
                opened):
    """Add splats ``first .. last - 1`` (:func:`splat_schedule`'s order) to the sheets of slabs ``k0 .. k0 +
    len(sheet) - 1`` (``sheet``, ``cores``: ``(slabs, pixels)``).  ``positions`` .. ``slab_range``:
    :func:`splat_schedule`'s; ``crossings``: ``(slabs + 1, pixels)`` where each pixel's ray crosses the
    group's slab boundaries (ray parameter); ``footprint``: ``F(q)`` for ``sigma = 1`` at ``q`` evenly over
    [0, 1]; ``cumulative``: ``Phi`` at evenly spaced standard deviations over ``+-radius / sigma``; ``core``:
    the splats' core flags, or empty (no culling).  The image's rows are split into
    ``bands`` taken in parallel (each pixel is one band's: the sums are the serial loop's).  ``opened[o -
    first]`` is set where a splat met a pixel below the threshold or lies off the image (the others are
    skipped by early termination; splats none of whose slabs is in the group are passed over)."""
    height = alpha.shape[0] // width
    for band in numba.prange(bands):
        row0 = band * height // bands
        row1 = (band + 1) * height // bands - 1
        for o in range(first, last):
            if slab_range[o, 1] < k0 or slab_range[o, 0] >= k0 + sheet.shape[0]:
                continue
            if rect[o, 1] < rect[o, 0] or rect[o, 3] < rect[o, 2]:
                opened[o - first] = True  # off the image: not skipped, just empty
                continue
            j0 = max(rect[o, 2], row0)
            j1 = min(rect[o, 3], row1)
            if j1 < j0:
                continue
            if _fill_splat(o, j0, j1, positions, values, core, rect, slab_range, origins, directions,
                           t0, t1, crossings, k0, inv_spacing, radius, sigma, footprint, cumulative, alpha, threshold,
                           width, sheet, cores):
                opened[o - first] = True


@numba.njit(cache=True)
def _fill_splat(s, j0, j1, positions, values, core, rect, slab_range, origins, directions, t0, t1, crossings,
                k0, inv_spacing, radius, sigma, footprint, cumulative, alpha, threshold, width, sheet, cores):
    """Splat ``s`` into the pixels of its rectangle's rows ``j0 .. j1``
    (:func:`fill_sheets`); whether any of them was below the threshold."""
    n_table = footprint.shape[0]
    r2 = radius * radius
    reach = radius / sigma  # the cumulative table's half range, standard deviations
    culling = core.shape[0] > 0
    slabs = sheet.shape[0]
    cx, cy, cz = positions[s, 0], positions[s, 1], positions[s, 2]
    v = values[s]
    open_pixel = False
    for j in range(j0, j1 + 1):
        for i in range(rect[s, 0], rect[s, 1] + 1):
            p = j * width + i
            lo = t0[p]
            hi = t1[p]
            if alpha[p] >= threshold:
                continue
            open_pixel = True
            if not hi > lo:
                continue
            dx = directions[p, 0] * inv_spacing[0]
            dy = directions[p, 1] * inv_spacing[1]
            dz = directions[p, 2] * inv_spacing[2]
            ux = (origins[p, 0] + lo * directions[p, 0] - cx) * inv_spacing[0]
            uy = (origins[p, 1] + lo * directions[p, 1] - cy) * inv_spacing[1]
            uz = (origins[p, 2] + lo * directions[p, 2] - cz) * inv_spacing[2]
            a = dx * dx + dy * dy + dz * dz
            tc = -(ux * dx + uy * dy + uz * dz) / a  # the nearest approach, from lo
            nx, ny, nz = ux + tc * dx, uy + tc * dy, uz + tc * dz
            q = (nx * nx + ny * ny + nz * nz) / r2
            if q >= 1.0:
                continue
            f = q * (n_table - 1)
            e = min(int(f), n_table - 2)
            w = f - e
            length = math.sqrt(a)  # voxels per world unit along the ray
            whole_footprint = ((1.0 - w) * footprint[e] + w * footprint[e + 1]) / (sigma * sigma) / length * v
            half_chord = radius * math.sqrt(1.0 - q)
            whole = 2.0 * _phi(half_chord / sigma, cumulative, reach) - 1.0  # the chord's share, erf
            # the slabs the chord crosses (the boundaries are even along the ray), a slab's margin for rounding
            step = crossings[1, p] - crossings[0, p]
            before = lo + tc - crossings[0, p]
            ka = max(slab_range[s, 0] - k0, int(math.floor((before - half_chord / length) / step)) - 1, 0)
            kb = min(slab_range[s, 1] - k0, int(math.floor((before + half_chord / length) / step)) + 1, slabs - 1)
            x_below = -half_chord  # the last boundary's place on the chord, and its erf (telescoping)
            erf_below = -whole
            for k in range(ka, kb + 1):
                a_k = max(lo, crossings[k, p]) - lo
                b_k = min(hi, crossings[k + 1, p]) - lo
                if not b_k > a_k:
                    continue
                x0 = max((a_k - tc) * length, -half_chord)
                x1 = min((b_k - tc) * length, half_chord)
                if not x1 > x0:
                    continue
                erf0 = erf_below if x0 == x_below else 2.0 * _phi(x0 / sigma, cumulative, reach) - 1.0
                erf1 = whole if x1 == half_chord else 2.0 * _phi(x1 / sigma, cumulative, reach) - 1.0
                x_below, erf_below = x1, erf1
                if whole > 2e-6:
                    share = (erf1 - erf0) / (2.0 * whole)
                else:
                    share = (x1 - x0) / (2.0 * half_chord)
                sheet[k, p] += whole_footprint * share
                if culling:
                    t = min(max(tc, a_k), b_k)
                    ox, oy, oz = ux + t * dx, uy + t * dy, uz + t * dz
                    if ox * ox + oy * oy + oz * oz <= 0.75:
                        cores[k, p] += core[s]
    return open_pixel


@numba.njit(cache=True)
def _phi(x, cumulative, reach):
    """``Phi(x)`` (``x`` in standard deviations) from ``cumulative`` over ``[-reach, reach]``, linearly
    interpolated (as ``splat.frag`` reads its texture, in float64): 0 and 1 beyond."""
    u = (x + reach) * ((cumulative.shape[0] - 1) / (2.0 * reach))
    if u <= 0.0:
        return 0.0
    if u >= cumulative.shape[0] - 1:
        return 1.0
    e = int(u)
    w = u - e
    return (1.0 - w) * cumulative[e] + w * cumulative[e + 1]


@numba.njit(cache=True)
def composite_sheets(sheet, cores, culling, t0, t1, along, bounds, k0, k1, table, domain_lo, domain_hi, image):
    """Composite the sheets of slabs ``k0 .. k1 - 1`` under ``image`` (``(pixels, 4)``, premultiplied,
    front to back); ``table``: ``(size, 4)`` colour and extinction at evenly spaced values over the
    domain."""
    size = table.shape[0]
    scale = (size - 1) / (domain_hi - domain_lo)
    for k in range(k0, k1):
        for p in range(image.shape[0]):
            lo = max(t0[p], bounds[k] / along[p])
            hi = min(t1[p], bounds[k + 1] / along[p])
            extent = hi - lo
            if not extent > 0.0 or not t1[p] > t0[p]:
                continue
            if culling and cores[k - k0, p] <= 0.0:
                continue  # no point of this part is near a core sample: transparent
            x = min(max((sheet[k - k0, p] / extent - domain_lo) * scale, 0.0), size - 1.0)
            e = min(int(x), size - 2)
            w = x - e
            sigma = (1.0 - w) * table[e, 3] + w * table[e + 1, 3]
            opacity = -math.expm1(-sigma * extent)
            under = (1.0 - image[p, 3]) * opacity
            for c in range(3):
                image[p, c] += under * ((1.0 - w) * table[e, c] + w * table[e + 1, c])
            image[p, 3] += under
