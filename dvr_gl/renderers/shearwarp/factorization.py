"""Shear-warp factorization of the viewing transformation (Lacroute and Levoy 1994).

Coordinates:

* *voxel* coordinates ``x`` (x, y, z order): sample ``(i, j, k)`` of the volume at
  integers, ``world = origin + x * spacing``;
* *permuted* coordinates ``q = P x = (i, j, k)``: ``k`` along the principal
  viewing axis ``c``, ``i`` and ``j`` along the axes ``(c + 1) % 3`` and
  ``(c + 2) % 3``, so slice ``k`` of the permuted volume is a 2D image
  ``[j, i]``;
* *intermediate* image coordinates ``(u, v)``: pixel centres at integers.  The
  intermediate image is the plane of the *front* slice (the one nearest the eye),
  one pixel per voxel of it, translated by ``(tu, tv)`` so that every slice lands
  at non-negative coordinates with a one-pixel border of zeros;
* final image pixel coordinates ``(px, py)``: pixel centres at ``col + 0.5``, row
  0 at the top (the conventions).

The *shear* ``S`` maps a point to where the ray through it meets the front
slice: parallel projection, ``u = i + sx (k - k_f) + tu`` with ``sx = -D_i / D_k``
for the viewing direction ``D`` in permuted coordinates; perspective, the ray from
the eye ``E``, ``u = E_i + (i - E_i) s_k + tu`` with the per-slice scale
``s_k = (E_k - k_f) / (E_k - k)`` (1 on the front slice, below 1 behind it: far
slices are minified, so an intermediate scanline gathers from more than one voxel
scanline).  Every point of one ray shears to the same ``(u, v)``, so the rest of
the viewing transformation, the *warp* ``M_warp`` from ``(u, v, 1)`` to
homogeneous ``(px w, py w, w)``, is a 2D transformation: affine for parallel
projection, projective (a homography) for perspective.  The viewing
transformation is ``M_view = W3 S P`` with ``W3`` independent of ``k``
(:meth:`Factorization.matrices`; tested to rounding).

A perspective eye inside the volume (inside the slab of slices of every axis) has no single
factorization: rays leave it in every direction.  The view is split as Lacroute (1995) splits it,
into the pyramids of rays sharing a principal axis and a direction along it (the six faces of a cube
around the eye): each final pixel belongs to the pyramid of its ray (:func:`pixel_directions`), and
each pyramid is factored apart (:func:`pyramid_factorization`) over the slices beyond the eye on its
side.  Its intermediate image cannot lie in the front slice's plane, which may be a hair from the
eye (every ray would pass through a few pixels); it lies in a plane ``base`` beyond the eye, as
far as makes one intermediate pixel about one final pixel at the image's centre, and covers only the
pyramid's pixels' rays (plus a margin for the warp's taps).  Slices nearer than it are magnified
(scale above 1), so each intermediate pixel gathers its sample bilinearly from the slice rather than
each voxel scattering to four pixels (``gather``).  :func:`factorize_view` gives one factorization,
or one per pyramid that the image sees.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ...errors import SceneError

EYE_MARGIN = 1e-3  # voxels: perspective needs the eye this far outside the slab of slices


def permuted_axes(axis: int) -> tuple[int, int, int]:
    """World axes ``(a, b, c)`` that become ``(i, j, k)`` for principal axis ``c``."""
    return (axis + 1) % 3, (axis + 2) % 3, axis


def camera_matrix(camera, width: int, height: int) -> np.ndarray:
    """4x4: world (homogeneous) to ``(px w, py w, depth-ish, w)`` final pixel coordinates.

    Orthographic: ``w = 1`` and the third row is the depth along the view axis;
    perspective: ``w`` is the depth and the third row is 1 (so ``Z / w`` is its inverse)."""
    f, r, up = camera.basis()
    eye = np.asarray(camera.eye)
    to_camera = np.zeros((4, 4))
    to_camera[0, :3], to_camera[1, :3], to_camera[2, :3] = r, up, f
    to_camera[:3, 3] = -to_camera[:3, :3] @ eye
    to_camera[3, 3] = 1.0
    half_w, half_h = camera.half_extent(width / height)
    k = np.zeros((4, 4))
    k[0, 0], k[1, 1] = width / (2.0 * half_w), -height / (2.0 * half_h)
    if camera.projection == "orthographic":
        k[0, 3], k[1, 3] = width / 2.0, height / 2.0
        k[2, 2], k[3, 3] = 1.0, 1.0
    else:
        k[0, 2], k[1, 2] = width / 2.0, height / 2.0
        k[2, 3], k[3, 2] = 1.0, 1.0
    return k @ to_camera


def voxel_to_world(volume) -> np.ndarray:
    m = np.diag([*volume.spacing, 1.0])
    m[:3, 3] = volume.origin
    return m


def permutation_matrix(axis: int) -> np.ndarray:
    """4x4 ``P``: voxel coordinates to permuted ``(i, j, k)``."""
    p = np.zeros((4, 4))
    for row, world_axis in enumerate(permuted_axes(axis)):
        p[row, world_axis] = 1.0
    p[3, 3] = 1.0
    return p


def eye_inside(camera, volume) -> bool:
    """Whether a perspective eye lies inside the slab of slices of every axis (no single factorization)."""
    if camera.projection == "orthographic":
        return False
    eye_voxel = (np.asarray(camera.eye) - volume.box[0]) / np.asarray(volume.spacing)
    n = np.asarray(volume.dims) - 1
    return not bool(((eye_voxel < -EYE_MARGIN) | (eye_voxel > n + EYE_MARGIN)).any())


def principal_axis(camera, volume) -> int:
    """The slice axis: the largest component of the viewing direction in voxel coordinates (so that
    consecutive slices shift by at most one voxel along a ray).  Perspective: the direction from the
    eye to the volume's centre, among the axes whose slab of slices the eye lies outside; an eye
    within every slab (inside the volume) cannot be sheared (``SceneError``)."""
    spacing = np.asarray(volume.spacing)
    lo, hi = volume.box
    if camera.projection == "orthographic":
        f, _, _ = camera.basis()
        return int(np.argmax(np.abs(f / spacing)))
    eye_voxel = (np.asarray(camera.eye) - lo) / spacing
    n = np.asarray(volume.dims) - 1
    outside = (eye_voxel < -EYE_MARGIN) | (eye_voxel > n + EYE_MARGIN)
    if not outside.any():
        raise SceneError("shearwarp: the perspective eye is inside the volume, where no slice axis has all "
                         "rays crossing the slices one way: factor the view by pyramids (factorize_view)")
    direction = np.abs(((lo + hi) / 2.0 - np.asarray(camera.eye)) / spacing)
    return int(np.argmax(np.where(outside, direction, -1.0)))


@dataclass(frozen=True)
class Factorization:
    """The factored view (see the module doc).  ``slices`` run front to back."""

    axis: int
    perspective: bool
    dims: tuple[int, int, int]        # permuted (Ni, Nj, Nk)
    front: int                        # k of the front slice
    step: int                         # +1 or -1: k order front to back
    shear: tuple[float, float]        # parallel: (sx, sy) per slice
    eye: tuple[float, float, float]   # perspective: the eye in permuted coordinates
    translation: tuple[float, float]  # (tu, tv)
    size: tuple[int, int]             # intermediate image (width, height), border included
    warp: np.ndarray                  # 3x3: (u, v, 1) -> (px w, py w, w)
    to_world: np.ndarray              # 4x4: permuted (i, j, k, 1) -> world
    base: float | None = None         # k of the intermediate image's plane (None: the front slice's)
    count: int | None = None          # slices composited (None: all dims[2])
    pyramid: tuple[int, int] | None = None  # (axis, sign): the pixels whose rays are this pyramid's

    @property
    def gather(self) -> bool:
        """Whether each pixel samples the slices (a pyramid of an eye inside) rather than each voxel
        scattering to its pixels."""
        return self.pyramid is not None

    @property
    def base_k(self) -> float:
        return float(self.front) if self.base is None else self.base

    @property
    def slices(self) -> np.ndarray:
        return self.front + self.step * np.arange(self.dims[2] if self.count is None else self.count)

    def slice_transform(self, k):
        """``(scale, offset_u, offset_v)``: slice ``k``'s voxel ``(i, j)`` lands at
        ``(scale i + offset_u, scale j + offset_v)`` in the intermediate image (``k`` may be an array)."""
        k = np.asarray(k, dtype=np.float64)
        tu, tv = self.translation
        if not self.perspective:
            sx, sy = self.shear
            return np.ones_like(k), sx * (k - self.front) + tu, sy * (k - self.front) + tv
        ei, ej, ek = self.eye
        scale = (ek - self.base_k) / (ek - k)
        return scale, ei * (1.0 - scale) + tu, ej * (1.0 - scale) + tv

    def front_points(self, u, v) -> np.ndarray:
        """World points ``(..., 3)`` on the intermediate image's plane at intermediate ``(u, v)``."""
        tu, tv = self.translation
        q = np.stack([np.asarray(u, float) - tu, np.asarray(v, float) - tv,
                      np.full(np.shape(u), self.base_k), np.ones(np.shape(u))], axis=-1)
        return (q @ self.to_world.T)[..., :3]

    def matrices(self, camera, width: int, height: int) -> dict:
        """``M_view`` (voxel to final image), ``P``, ``S`` and ``W3 = M_view P^-1 S^-1`` (4x4 each)."""
        tu, tv = self.translation
        s = np.eye(4)
        if not self.perspective:
            sx, sy = self.shear
            s[0, 2], s[0, 3] = sx, tu - sx * self.front
            s[1, 2], s[1, 3] = sy, tv - sy * self.front
        else:
            ei, ej, ek = self.eye
            depth = ek - self.base_k
            for row, (e, t) in enumerate(((ei, tu), (ej, tv))):
                s[row, 2], s[row, 3] = -(e + t) / depth, (e + t) * ek / depth - e
            s[3, 2], s[3, 3] = -1.0 / depth, ek / depth
        # s maps (i, j, k, 1) to (u w, v w, k, w); for parallel projection w = 1
        view = camera_matrix(camera, width, height)
        p = permutation_matrix(self.axis)
        return {"view": view @ self.to_world @ p, "P": p, "S": s, "W3": view @ self.to_world @ np.linalg.inv(s)}


def factorize(camera, volume, width: int, height: int) -> Factorization:
    """Factor the view of ``volume`` by ``camera`` into an ``(width, height)`` image."""
    axis = principal_axis(camera, volume)
    a, b, c = permuted_axes(axis)
    n = np.asarray(volume.dims)
    dims = (int(n[a]), int(n[b]), int(n[c]))
    p = permutation_matrix(axis)
    to_world = voxel_to_world(volume) @ np.linalg.inv(p)
    spacing = np.asarray(volume.spacing)
    perspective = camera.projection == "perspective"
    if perspective:
        eye_voxel = (np.asarray(camera.eye) - np.asarray(volume.origin)) / spacing
        eye = (float(eye_voxel[a]), float(eye_voxel[b]), float(eye_voxel[c]))
        front, step = (0, 1) if eye[2] < 0 else (dims[2] - 1, -1)
        shear = (0.0, 0.0)
    else:
        f, _, _ = camera.basis()
        d = f / spacing
        shear = (float(-d[a] / d[c]), float(-d[b] / d[c]))
        front, step = (0, 1) if d[c] > 0 else (dims[2] - 1, -1)
        eye = (0.0, 0.0, 0.0)
    probe = Factorization(axis, perspective, dims, front, step, shear, eye, (0.0, 0.0), (0, 0), np.eye(3), to_world)
    # the slices' extent fixes the translation and size, and those the warp
    k = np.arange(dims[2])
    scale, ou, ov = probe.slice_transform(k)
    pad = [0.5 if n == 1 else 0.0 for n in dims]  # a single sample spans half a voxel either side
    lo_u, hi_u = np.min(ou - scale * pad[0]), np.max(ou + scale * (dims[0] - 1 + pad[0]))
    lo_v, hi_v = np.min(ov - scale * pad[1]), np.max(ov + scale * (dims[1] - 1 + pad[1]))
    # one pixel of zeros on every side: bilinear warping then fades to transparent at the edges
    tu, tv = 1.0 - math.floor(lo_u), 1.0 - math.floor(lo_v)
    size = (int(math.floor(hi_u) + tu) + 3, int(math.floor(hi_v) + tv) + 3)
    fact = dataclasses.replace(probe, translation=(tu, tv), size=size)
    w3 = fact.matrices(camera, width, height)["W3"]
    return dataclasses.replace(fact, warp=w3[np.ix_([0, 1, 3], [0, 1, 3])])


def pixel_directions(camera, volume, width: int, height: int) -> np.ndarray:
    """3x3 ``M``: a final pixel's ray direction in voxel units (world direction over the spacing,
    x, y, z order), unnormalized, ``M @ (px, py, 1)`` for pixel coordinates ``px = col + 0.5``,
    ``py = row + 0.5`` (row 0 at the top), as :meth:`dvr_gl.camera.Camera.pixel_rays` builds them;
    ``shaders/warp.frag`` assigns pixels to pyramids with it (PYRAMID)."""
    f, right, up = (np.asarray(v, dtype=np.float64) for v in camera.basis())
    half_w, half_h = camera.half_extent(width / height)
    world = np.stack([2.0 * half_w / width * right, -2.0 * half_h / height * up,
                      f - half_w * right + half_h * up], axis=1)
    return world / np.asarray(volume.spacing, dtype=np.float64)[:, None]


def pixel_pyramids(camera, volume, width: int, height: int):
    """Every final pixel's ray direction in voxel units ``(H * W, 3)``, row-major from the top, and its
    pyramid (:func:`pyramid_of`: axis and sign, ``(H * W,)`` each)."""
    py, px = np.mgrid[0:height, 0:width] + 0.5
    directions = np.stack([px.ravel(), py.ravel(), np.ones(px.size)], axis=1) @ \
        pixel_directions(camera, volume, width, height).T
    return (directions, *pyramid_of(directions))


def pyramid_of(directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pyramid of each direction ``(N, 3)`` (voxel units): its principal axis (the largest
    component's; ties to the lower axis, as ``argmax`` and warp.frag) and the sign along it."""
    axis = np.argmax(np.abs(directions), axis=1)
    return axis, np.sign(directions[np.arange(len(directions)), axis]).astype(np.int64)


def factorize_view(camera, volume, width: int, height: int) -> list[Factorization]:
    """The view's factorizations: one (:func:`factorize`), or with a perspective eye inside the volume
    one per pyramid that the image's pixels see and that has slices beyond the eye."""
    if not eye_inside(camera, volume):
        return [factorize(camera, volume, width, height)]
    directions, axes, signs = pixel_pyramids(camera, volume, width, height)
    out = []
    for axis, sign in sorted(set(zip(axes.tolist(), signs.tolist()))):
        mine = (axes == axis) & (signs == sign)
        fact = pyramid_factorization(camera, volume, width, height, axis, sign, directions[mine])
        if fact is not None:
            out.append(fact)
    return out


def pyramid_factorization(camera, volume, width: int, height: int, axis: int, sign: int,
                          directions: np.ndarray) -> Factorization | None:
    """The factorization of pyramid ``(axis, sign)`` for its pixels' ray ``directions`` (voxel units):
    the slices beyond the eye on that side (None where there are none), the intermediate image in
    the plane ``base`` (see the module doc) over those rays' crossings with it, two pixels of margin."""
    a, b, c = permuted_axes(axis)
    n = np.asarray(volume.dims)
    dims = (int(n[a]), int(n[b]), int(n[c]))
    p = permutation_matrix(axis)
    to_world = voxel_to_world(volume) @ np.linalg.inv(p)
    spacing = np.asarray(volume.spacing, dtype=np.float64)
    eye_voxel = (np.asarray(camera.eye) - np.asarray(volume.origin)) / spacing
    eye = (float(eye_voxel[a]), float(eye_voxel[b]), float(eye_voxel[c]))
    if sign > 0:
        front = int(math.floor(eye[2])) + 1      # the first slice beyond the eye
        count, step = dims[2] - front, 1
    else:
        front = int(math.ceil(eye[2])) - 1
        count, step = front + 1, -1
    if count <= 0:
        return None
    # one intermediate pixel (one voxel across a and b) about one final pixel at the image's centre
    pixel = 2.0 * camera.half_extent(width / height)[1] / height  # tan units per final pixel
    across = min(spacing[a], spacing[b]) / (spacing[c] * pixel)
    base = eye[2] + sign * max(across, 1.0)
    d = directions[:, [a, b, c]]
    reach = (base - eye[2]) / d[:, 2]
    u, v = eye[0] + d[:, 0] * reach, eye[1] + d[:, 1] * reach
    tu, tv = 2.0 - math.floor(u.min()), 2.0 - math.floor(v.min())
    size = (int(math.floor(u.max()) + tu) + 4, int(math.floor(v.max()) + tv) + 4)
    fact = Factorization(axis, True, dims, front, step, (0.0, 0.0), eye, (tu, tv), size, np.eye(3), to_world,
                         base=base, count=count, pyramid=(axis, sign))
    w3 = fact.matrices(camera, width, height)["W3"]
    return dataclasses.replace(fact, warp=w3[np.ix_([0, 1, 3], [0, 1, 3])])
