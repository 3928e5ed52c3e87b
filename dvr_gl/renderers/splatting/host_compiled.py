"""Image-aligned post-classified sheets of Gaussian splats on the host, compiled with numba (the optional
extra ``numba``); imported only through :func:`.host.compiled`, which leaves the frame to GL where numba is
not installed.

Both loops compute what ``shaders/splat.frag`` (``kernel_integral``) and ``shaders/sheet.frag`` compute per
fragment, in float64 with the closed-form ``erf`` instead of the cumulative table:

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


@numba.njit(cache=True)
def fill_sheets(first, last, positions, values, core, rect, slab_range, origins, directions, t0, t1, crossings,
                k0, inv_spacing, radius, sigma, footprint, alpha, threshold, width, sheet, cores):
    """Add splats ``first .. last - 1`` to the sheets of slabs ``k0 .. k0 + len(sheet) - 1`` (``sheet``,
    ``cores``: ``(slabs, pixels)``).  ``rect``: ``(n, 4)`` columns and rows ``i0, i1, j0, j1`` (inclusive);
    ``slab_range``: ``(n, 2)`` the first and last slab each kernel reaches; ``crossings``: ``(slabs + 1,
    pixels)`` where each pixel's ray crosses the group's slab boundaries (ray parameter); ``footprint``:
    ``F(q)`` for ``sigma = 1`` at ``q`` evenly over [0, 1]; ``core``: the splats' core flags, or empty (no
    culling).  Returns the splats skipped: every pixel of their rectangle opaque (early termination)."""
    n_table = footprint.shape[0]
    r2 = radius * radius
    erf_scale = 1.0 / (sigma * math.sqrt(2.0))
    culling = core.shape[0] > 0
    slabs = sheet.shape[0]
    skipped = 0
    for s in range(first, last):
        cx, cy, cz = positions[s, 0], positions[s, 1], positions[s, 2]
        v = values[s]
        open_pixel = rect[s, 1] < rect[s, 0] or rect[s, 3] < rect[s, 2]  # off the image: not skipped, just empty
        for j in range(rect[s, 2], rect[s, 3] + 1):
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
                whole = math.erf(half_chord * erf_scale)
                ka = max(slab_range[s, 0], k0) - k0
                kb = min(slab_range[s, 1], k0 + slabs - 1) - k0
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
                    erf0 = erf_below if x0 == x_below else math.erf(x0 * erf_scale)
                    erf1 = whole if x1 == half_chord else math.erf(x1 * erf_scale)
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
        if not open_pixel:
            skipped += 1
    return skipped


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
