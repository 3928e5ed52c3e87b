"""Closed forms for the conformance tests: scenes whose images are known exactly (or between two
exactly known bounds), for every compositing mode.

* ``box``: constant data in a box, constant colour and extinction: emission-absorption gives
  ``1 - exp(-sigma L)`` over the chord ``L``; the projections (average, MIP, MinIP) classify the
  constant with the opacity of one unit distance; the isosurface is hit at the entry point.
* ``ramp``: data ``= x`` (world), extinction linear in the value: the optical depth is the chord times
  the mean of the extinction at its ends; MIP and MinIP are the larger and smaller end values, the
  average their mean, the isosurface is hit where the chord reaches the iso-value.
* ``sphere``: data ``R^2 - |p - c|^2``, extinction ``k max(value, 0)``: a ball of density falling
  to zero at radius ``R``, whose optical depth along a ray at distance ``b`` from the centre is
  ``k 4/3 (R^2 - b^2)^(3/2)``; MIP is ``R^2`` minus the squared distance of the chord's point
  nearest the centre; the isosurface is the sphere where the value is the iso-value.  Trilinear
  interpolation of the quadratic data underestimates it by ``e`` with ``0 <= e <= 3 h^2 / 4``
  (per axis, linear interpolation of ``x^2`` errs by ``(x - x0)(x1 - x) <= h^2 / 4``), so the
  grid's picture lies between the closed forms for ``R^2`` and ``R^2 - 3 h^2 / 4``: the bounds.
* ``analytic sphere`` (data kind ``analytic``): a ball of constant material, the field itself
  exact (:class:`dvr_gl.fields.SphereField`): ``1 - exp(-sigma 2 sqrt(R^2 - b^2))``.
* ``mesh boxes`` (data kind ``mesh``): two boxes of hexahedra (split into tetrahedra when read)
  with a gap between them, one constant cell scalar: Beer-Lambert on the sum of the two chords (a
  non-convex mesh: nothing in the gap); the projections as for ``box``.
* ``two channels`` (data kind ``fields``): two constant channels on one grid, each with its own colour and
  extinction, composited per sample: ``exp(-(s1 + s2) L)`` and the extinction-weighted colour; the
  per-channel projections add each channel's classified colour.
* ``mesh ramp`` (``mesh``): a box of hexahedra with its interior points moved, point scalar ``= x``
  (linear, so every tetrahedron holds it exactly): the closed forms of ``ramp``.

Each :class:`ClosedForm` gives the scene for a mode and view, and ``bounds(scene)``: per pixel, the
lowest and highest value the exact image can take, and which pixels are compared (those at least a
margin away from a silhouette or an iso-value crossing, where "hit or miss" is decided by less than
the discretization: excluded, and counted).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from dvr_gl.fields import SphereField
from dvr_gl.rays import RayBatch, intersect_box
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from dvr_gl.scene.settings import DEFAULT_SAMPLE_DISTANCE_VOXELS

WIDTH, HEIGHT = 24, 20
COLOUR = np.array([0.9, 0.5, 0.2])
VIEWS = {
    "perspective": {"camera.projection": "perspective", "camera.fov": 35.0, "camera.azimuth": 27.0,
                    "camera.elevation": 21.0},
    "orthographic": {"camera.projection": "orthographic", "camera.azimuth": -38.0, "camera.elevation": 33.0},
}


@dataclass
class ClosedForm:
    name: str
    kind: str                         # the data kind of its scenes
    modes: tuple
    scene: Callable                   # (tmp_path, mode, view, renderer) -> Scene
    bounds: Callable                  # (scene) -> (lo (H, W, 4), hi (H, W, 4), compared (H, W))


def _save(tmp_path, name, data):
    path = tmp_path / f"{name}.npy"
    if not path.exists():
        np.save(path, data)
    return str(path)


def own_filter(renderer, mode: str = "emission_absorption") -> dict:
    """The filter (and classification) a renderer is tested with: the scene's defaults where it takes
    them, else its first (splatting takes its kernels only; Fourier rendering's X-ray classifies voxels)."""
    p = registry.plugin(renderer)
    choices = p.choices("filter")
    out = {} if "linear" in choices else {"renderer.filter": choices[0]}
    classifications = p.choices("classification")
    if mode in ("emission_absorption", "xray") and classifications and "post" not in classifications:
        out["renderer.classification"] = classifications[0]
    return out


def _load(data_keys, points, mode, view, renderer, extra=None):
    """A closed form's scene: its data keys, extinction ``points``, the view, no early termination; the unit
    distance 1 world unit, stated (the projections' opacity is that of one unit distance)."""
    # The fixed sample distance (0.5 voxel) where the renderer takes one: the tolerances were measured there,
    # and the ray caster's default is otherwise chosen by the scene for an 8-bit display (issue 44), a
    # coarser step than a closed form checked to float32 rounding needs.
    fixed = {"renderer.sample_distance_voxels": DEFAULT_SAMPLE_DISTANCE_VOXELS} \
        if "sample_distance_voxels" in registry.plugin(renderer).setting_names \
        and not any(k.startswith("renderer.sample_distance") for k in {**data_keys, **(extra or {})}) else {}
    overrides = {**own_filter(renderer, mode), **data_keys, **fixed, "transfer_function.points": points,
                 "transfer_function.opacity_model": "extinction", "transfer_function.unit_distance": 1.0,
                 "image.width": WIDTH, "image.height": HEIGHT,
                 "renderer.name": renderer, "renderer.compositing": mode, "renderer.ert_threshold": 1.0,
                 "renderer.converged_tolerance": 1e-6, **VIEWS[view], **(extra or {})}
    return load_scene(None, overrides)


def _scene(tmp_path, name, data, spacing, origin, points, mode, view, renderer, extra=None):
    return _load({"volume.path": _save(tmp_path, name, data), "volume.spacing": list(spacing),
                  "volume.origin": list(origin)}, points, mode, view, renderer, extra)


def _rays(scene):
    """The pixels' rays and their part inside the box (empty for misses), as the references clip them."""
    rays = RayBatch.for_camera(scene.camera, scene.image.width, scene.image.height, scene.field.bounds)
    return rays.origins, rays.directions, rays.t0, rays.t1


def _margin_mask(scene, margin):
    """Pixels whose rays pass at least ``margin`` inside the box, or miss it by at least ``margin``."""
    lo, hi = (np.asarray(b) for b in scene.field.bounds)
    o, d = scene.camera.pixel_rays(scene.image.width, scene.image.height)
    a0, a1 = intersect_box(o, d, lo + margin, hi - margin)
    b0, b1 = intersect_box(o, d, lo - margin, hi + margin)
    return ((a1 > a0) | ~(b1 > b0)).reshape(scene.image.height, scene.image.width)


def _rgba(colour, alpha):
    return np.concatenate([colour * alpha[..., None], alpha[..., None]], axis=-1)


def _image(values, scene):
    return values.reshape(scene.image.height, scene.image.width, -1)


def _classified(value, sigma, unit=1.0):
    """Projections classify the value once, with the opacity of one unit distance."""
    return _rgba(COLOUR, -np.expm1(-sigma(value) * unit))


# --- box ---------------------------------------------------------------------------------------

BOX_VALUE, BOX_SIGMA, BOX_ISO = 0.6, 0.9, 0.3


def _box_scene(tmp_path, mode, view, renderer):
    data = np.full((5, 6, 7), BOX_VALUE, np.float32)
    points = [[0.0, *COLOUR, BOX_SIGMA], [1.0, *COLOUR, BOX_SIGMA]]
    return _scene(tmp_path, "box", data, (0.5, 0.6, 0.7), (0.0, 0.0, 0.0), points, mode, view, renderer,
                  {"renderer.iso_value": BOX_ISO})


def _box_bounds(scene):
    mode = scene.renderer.compositing
    _, _, t0, t1 = _rays(scene)
    length = t1 - t0
    hit = length > 0
    if mode in ("emission_absorption", "xray"):  # one colour: the radiograph is Beer-Lambert too
        rgba = _rgba(COLOUR, -np.expm1(-BOX_SIGMA * length))
    elif mode == "isosurface":
        rgba = _rgba(COLOUR, hit.astype(float))
    else:
        rgba = np.where(hit[:, None],
                        _classified(np.full(len(hit), BOX_VALUE), lambda v: BOX_SIGMA * np.ones_like(v)), 0.0)
    image = _image(rgba, scene)
    return image, image, _margin_mask(scene, 0.05)


# --- ramp --------------------------------------------------------------------------------------

RAMP_A, RAMP_B = 0.1, 0.25     # sigma = a + b * value
RAMP_ISO = 1.7


def _ramp_sigma(v):
    return RAMP_A + RAMP_B * v


def _ramp_scene(tmp_path, mode, view, renderer):
    nx, spacing = 9, (0.45, 0.5, 0.55)
    x = np.arange(nx, dtype=np.float32) * np.float32(spacing[0])
    data = np.broadcast_to(x, (6, 7, nx)).copy()
    top = float(x[-1])
    points = [[0.0, *COLOUR, _ramp_sigma(0.0)], [top, *COLOUR, _ramp_sigma(top)]]
    return _scene(tmp_path, "ramp", data, spacing, (0.0, 0.0, 0.0), points, mode, view, renderer,
                  {"renderer.iso_value": RAMP_ISO})


def _ramp_bounds(scene):
    mode = scene.renderer.compositing
    o, d, t0, t1 = _rays(scene)
    hit = t1 > t0
    x_in, x_out = o[:, 0] + t0 * d[:, 0], o[:, 0] + t1 * d[:, 0]
    compared = _margin_mask(scene, 0.05)
    if mode in ("emission_absorption", "xray"):  # one colour: the radiograph is Beer-Lambert too
        rgba = _rgba(COLOUR, -np.expm1(-(t1 - t0) * (_ramp_sigma(x_in) + _ramp_sigma(x_out)) / 2))
    elif mode == "isosurface":
        reached = np.maximum(x_in, x_out)
        rgba = _rgba(COLOUR, (hit & (reached >= RAMP_ISO)).astype(float))
        compared &= _image(np.abs(reached - RAMP_ISO) > 0.05, scene)[..., 0]
    else:
        value = {"mip": np.maximum(x_in, x_out), "minip": np.minimum(x_in, x_out), "average": (x_in + x_out) / 2}[mode]
        rgba = np.where(hit[:, None], _classified(value, _ramp_sigma), 0.0)
    image = _image(rgba, scene)
    return image, image, compared


# --- sphere (sampled) ------------------------------------------------------------------------

SPHERE_N, SPHERE_H, SPHERE_R, SPHERE_K = 17, 0.5, 3.0, 0.06
SPHERE_ISO = 4.0


def _sphere_grid():
    half = (SPHERE_N - 1) / 2 * SPHERE_H
    axis = np.arange(SPHERE_N) * SPHERE_H - half
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    return (SPHERE_R ** 2 - (x * x + y * y + z * z)).astype(np.float32), -half


def _sphere_scene(tmp_path, mode, view, renderer):
    data, corner = _sphere_grid()
    top = SPHERE_R ** 2
    points = [[0.0, *COLOUR, 0.0], [top, *COLOUR, SPHERE_K * top]]
    return _scene(tmp_path, "sphere", data, (SPHERE_H,) * 3, (corner,) * 3, points, mode, view, renderer,
                  {"renderer.iso_value": SPHERE_ISO})


def _chord_geometry(o, d):
    """Squared distance ``b^2`` of each ray's line from the centre (the origin), and the parameter of
    its closest point."""
    s = -np.sum(o * d, axis=1)
    b2 = np.maximum(np.sum(o * o, axis=1) - s * s, 0.0)
    return b2, s


def _sphere_bounds(scene):
    mode = scene.renderer.compositing
    o, d, t0, t1 = _rays(scene)
    hit = t1 > t0
    b2, s = _chord_geometry(o, d)
    bias = 3.0 * SPHERE_H ** 2 / 4.0            # trilinear interpolation of the quadratic: 0 <= e <= bias
    compared = _margin_mask(scene, 0.05)
    if mode in ("emission_absorption", "xray"):  # one colour: the radiograph is Beer-Lambert too
        def alpha(r2):
            return -np.expm1(-SPHERE_K * 4.0 / 3.0 * np.maximum(r2 - b2, 0.0) ** 1.5)
        lo, hi = _rgba(COLOUR, alpha(SPHERE_R ** 2 - bias)), _rgba(COLOUR, alpha(SPHERE_R ** 2))
    elif mode == "mip":
        nearest = np.clip(s, t0, t1)             # the chord's point nearest the centre
        p = o + nearest[:, None] * d
        top = SPHERE_R ** 2 - np.sum(p * p, axis=1)

        def rgba(v):
            return np.where(hit[:, None], _classified(v, lambda x: SPHERE_K * np.maximum(x, 0.0)), 0.0)
        lo, hi = rgba(top - bias), rgba(top)
    elif mode == "isosurface":
        nearest = np.clip(s, t0, t1)
        p = o + nearest[:, None] * d
        top = SPHERE_R ** 2 - np.sum(p * p, axis=1)
        lo = hi = _rgba(COLOUR, (hit & (top >= SPHERE_ISO)).astype(float))
        compared &= _image((top >= SPHERE_ISO + bias + 0.05) | (top < SPHERE_ISO - 0.05), scene)[..., 0]
    else:
        raise ValueError(mode)
    return _image(lo, scene), _image(hi, scene), compared


# --- the analytic sphere (data kind "analytic") --------------------------------------------------

def _analytic_scene(tmp_path, mode, view, renderer):
    box = _sphere_scene(tmp_path, mode, view, renderer)
    points = [[0.0, *COLOUR, 0.0], [1.0, *COLOUR, 0.5]]
    field = SphereField((0.0, 0.0, 0.0), SPHERE_R, bounds=box.field.bounds, sample_spacing=SPHERE_H)
    from dvr_gl.transfer_function import TransferFunction

    return box.replace(field=field, camera=box.camera,
                       transfer_function=TransferFunction(np.array(points), opacity_model="extinction"))


def _analytic_bounds(scene):
    o, d, t0, t1 = _rays(scene)
    b2, _ = _chord_geometry(o, d)
    chord = 2.0 * np.sqrt(np.maximum(SPHERE_R ** 2 - b2, 0.0))
    image = _image(_rgba(COLOUR, -np.expm1(-0.5 * chord)), scene)
    edge = np.abs(np.sqrt(b2) - SPHERE_R) > 0.05
    return image, image, _image(edge, scene)[..., 0]


ALL_MODES = ("emission_absorption", "isosurface", "average", "mip", "minip", "xray")
# --- meshes ------------------------------------------------------------------------------------

MESH_BOXES = (((0.0, 0.0, 0.0), (1.0, 1.2, 1.4)), ((1.6, 0.0, 0.0), (2.6, 1.2, 1.4)))
MESH_RAMP_SIZE = (3.6, 2.5, 2.75)


def _hex_block(n, lo, hi, jitter=0.0, seed=0):
    """Points (i fastest) and hexahedra (VTK order) of an ``n`` grid over ``[lo, hi]``; interior
    points moved by up to ``jitter`` cells."""
    from dvr_gl.fields.mesh_cells import hexahedra_of_grid

    axes = [np.linspace(a, b, k) for a, b, k in zip(lo, hi, n)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    if jitter:
        inner = np.all([(p[:, i] > lo[i]) & (p[:, i] < hi[i]) for i in range(3)], axis=0)
        step = (np.array(hi) - np.array(lo)) / (np.array(n) - 1)
        p[inner] += np.random.default_rng(seed).uniform(-jitter, jitter, (inner.sum(), 3)) * step
    return p, hexahedra_of_grid(*n)


def _mesh_file(tmp_path, name, points, hexes, point_data=None, cell_data=None) -> str:
    import pytest

    meshio = pytest.importorskip("meshio", reason="meshes are read with meshio (pip install 'dvr-gl[mesh]')")
    path = tmp_path / f"{name}.vtu"
    if not path.exists():
        meshio.write(str(path), meshio.Mesh(points, [("hexahedron", hexes)], point_data=point_data or {},
                                            cell_data={k: [v] for k, v in (cell_data or {}).items()}))
    return str(path)


MESH_SAMPLE_DISTANCE = 0.02  # world: renderers that sample (the discrete reference) resolve the gap


def _mesh_scene(path, points, mode, view, renderer, extra=None):
    return _load({"volume.path": path, "renderer.sample_distance": MESH_SAMPLE_DISTANCE}, points, mode, view,
                 renderer, extra)


def _mesh_boxes_scene(tmp_path, mode, view, renderer):
    blocks = [_hex_block((3, 2, 2), lo, hi) for lo, hi in MESH_BOXES]
    points = np.concatenate([p for p, _ in blocks])
    hexes = np.concatenate([blocks[0][1], blocks[1][1] + len(blocks[0][0])])
    path = _mesh_file(tmp_path, "mesh-boxes", points, hexes, cell_data={"value": np.full(len(hexes), BOX_VALUE)})
    tf = [[0.0, *COLOUR, BOX_SIGMA], [1.0, *COLOUR, BOX_SIGMA]]
    return _mesh_scene(path, tf, mode, view, renderer, {"renderer.iso_value": BOX_ISO})


def _mesh_boxes_bounds(scene):
    mode = scene.renderer.compositing
    o, d, t0, t1 = _rays(scene)
    length = np.zeros(len(o))
    compared = np.ones((scene.image.height, scene.image.width), bool)
    for lo, hi in MESH_BOXES:
        a, b = intersect_box(o, d, np.array(lo), np.array(hi))
        length += np.maximum(b - np.maximum(a, 0.0), 0.0)
        a0, a1 = intersect_box(o, d, np.array(lo) + 0.05, np.array(hi) - 0.05)
        b0, b1 = intersect_box(o, d, np.array(lo) - 0.05, np.array(hi) + 0.05)
        compared &= _image((a1 > a0) | ~(b1 > b0), scene)[..., 0]
    hit = length > 0
    if mode in ("emission_absorption", "xray"):  # one colour: the radiograph is Beer-Lambert too
        rgba = _rgba(COLOUR, -np.expm1(-BOX_SIGMA * length))
    elif mode == "isosurface":
        rgba = _rgba(COLOUR, hit.astype(float))
    else:
        rgba = np.where(hit[:, None], _classified(np.full(len(hit), BOX_VALUE),
                                                  lambda v: BOX_SIGMA * np.ones_like(v)), 0.0)
    image = _image(rgba, scene)
    return image, image, compared


def _mesh_ramp_scene(tmp_path, mode, view, renderer):
    points, hexes = _hex_block((5, 3, 3), (0.0, 0.0, 0.0), MESH_RAMP_SIZE, jitter=0.25, seed=7)
    path = _mesh_file(tmp_path, "mesh-ramp", points, hexes, point_data={"x": points[:, 0]})
    top = MESH_RAMP_SIZE[0]
    tf = [[0.0, *COLOUR, _ramp_sigma(0.0)], [top, *COLOUR, _ramp_sigma(top)]]
    return _mesh_scene(path, tf, mode, view, renderer, {"renderer.iso_value": RAMP_ISO})


# --- two channels (data kind "fields") -----------------------------------------------------------

CHANNELS = ((0.6, np.array([0.9, 0.5, 0.2]), 0.9), (0.3, np.array([0.1, 0.4, 0.9]), 0.5))  # value, colour, sigma


def _channels_scene(tmp_path, mode, view, renderer):
    """Two constant channels on one grid, each with its own colour and extinction: per sample the extinctions
    add and the emissions add (docs/several-fields.md).  The second channel's iso-value lies above its value,
    so the isosurface is the first channel's, hit at the entry point."""
    tables = []
    for k, (value, colour, sigma) in enumerate(CHANNELS):
        path = _save(tmp_path, f"channel{k}", np.full((5, 6, 7), value, np.float32))
        tables.append({"path": path, "spacing": [0.5, 0.6, 0.7], "iso_value": 0.3 if k == 0 else 0.9,
                       "transfer_function": {"points": [[0.0, *colour, sigma], [1.0, *colour, sigma]],
                                             "opacity_model": "extinction", "unit_distance": 1.0}})
    overrides = {**own_filter(renderer, mode), "image.width": WIDTH, "image.height": HEIGHT,
                 "renderer.name": renderer, "renderer.compositing": mode, "renderer.ert_threshold": 1.0,
                 "renderer.converged_tolerance": 1e-6, **VIEWS[view]}
    return load_scene(None, overrides, base={"volume": tables})


def _channels_bounds(scene):
    """Emission-absorption and the radiograph: transmittance ``exp(-(s1 + s2) L)`` and the extinction-weighted
    colour; the per-channel projections: each constant classified alone (opacity of one unit distance), colours
    added, alpha ``1 - (1 - a1)(1 - a2)``; the isosurface: the first channel's colour, opaque."""
    mode = scene.renderer.compositing
    _, _, t0, t1 = _rays(scene)
    length = t1 - t0
    hit = (length > 0)[:, None]
    (_, c1, s1), (_, c2, s2) = CHANNELS
    if mode in ("emission_absorption", "xray"):
        rgba = _rgba((s1 * c1 + s2 * c2) / (s1 + s2), -np.expm1(-(s1 + s2) * length))
    elif mode == "isosurface":
        rgba = np.where(hit, np.append(c1, 1.0), 0.0)
    else:
        a1, a2 = -np.expm1(-s1), -np.expm1(-s2)
        rgba = np.where(hit, np.append(a1 * c1 + a2 * c2, 1.0 - (1.0 - a1) * (1.0 - a2)), 0.0)
    image = _image(rgba, scene)
    return image, image, _margin_mask(scene, 0.05)


CLOSED_FORMS = {cf.name: cf for cf in (
    ClosedForm("box", "grid", ALL_MODES, _box_scene, _box_bounds),
    ClosedForm("ramp", "grid", ALL_MODES, _ramp_scene, _ramp_bounds),
    ClosedForm("sphere", "grid", ("emission_absorption", "mip", "isosurface"), _sphere_scene, _sphere_bounds),
    ClosedForm("analytic sphere", "analytic", ("emission_absorption",), _analytic_scene, _analytic_bounds),
    ClosedForm("mesh boxes", "mesh", ALL_MODES, _mesh_boxes_scene, _mesh_boxes_bounds),
    ClosedForm("mesh ramp", "mesh", ALL_MODES, _mesh_ramp_scene, _ramp_bounds),
    ClosedForm("two channels", "fields", ALL_MODES, _channels_scene, _channels_bounds),
)}


def error_outside(image, lo, hi, compared) -> float:
    """The largest amount by which ``image`` leaves [lo, hi] on the compared pixels."""
    image = np.asarray(image, dtype=np.float64)
    excess = np.maximum(lo - image, 0.0) + np.maximum(image - hi, 0.0)
    return float(excess[compared].max(initial=0.0))

