"""Several fields in the references (data kind ``"fields"``, :mod:`dvr_gl.fields.layers`): the mixture of the
members' optical models, in float64.

Each member is classified by its role's model in its own scene (:mod:`.members`: a scalar's single-field
:class:`~dvr_gl.reference.model.OpticalModel` of its grid, transfer function and iso-value with the scene's
filter, classification, shading and gradient opacity; a label map's table; a colour volume's data), and
contributes only inside its own box (closed; world units, its own frame: an oriented member's points are mapped
there, :class:`~.members.OrientedField`, and its box is an oriented box in the shared frame).  The rays and
their segments span the union of the boxes (their shared-frame bounding boxes).  The mixture at a point
(docs/several-fields.md):

* emission-absorption and the X-ray: extinctions add and emissions add, ``sigma = sum_i sigma_i`` and
  ``sigma c = sum_i sigma_i c_i`` (so ``c`` is their ratio, 0 where ``sigma = 0``); each ``c_i`` shaded by
  member i's own gradient, each ``sigma_i`` scaled by its own gradient opacity, before mixing;
* pre-integrated classification: each member's own table gives ``(C_i, tau_i)`` for a segment whose sample
  lies in its box; ``tau = sum_i tau_i`` and ``C = sum_i C_i g(tau_i) / g(tau)`` with
  ``g(x) = x / (1 - exp(-x))`` (``g(0) = 1``): exact for constant fields, where ``C_i = c_i (1 - exp(-tau_i))``;
* per-channel projections (MIP, MinIP, average; scalar members only): each member's own projection over its
  samples inside its box (the converged reference: over its chord of the box), classified by its own transfer
  function with the opacity of one ``unit_distance`` (``a_i``, ``c_i``); the pixel's premultiplied colour
  ``sum_i a_i c_i``, its alpha ``1 - prod_i (1 - a_i)``;
* a scalar member's 2D transfer function (value and gradient magnitude) classifies it as in one field's scene (its
  own gradient); a label or rgb member with one is refused (:func:`check`);
* isosurface: the first sample of any member with ``v_i >= iso_i`` (ties: the member listed first), refined
  by bisection on that member alone; its transfer function's colour at its iso-value, shaded by its gradient.
"""

from __future__ import annotations

import numpy as np

from ..errors import SceneError
from ..fields.reconstruction import smooth_pieces
from ..rays import intersect_box
from ..transfer_function_2d import is_2d
from .members import member_scene, optics
from .model import depth_cue

#: the roles the references classify (:data:`dvr_gl.fields.layers.ROLES`; each as :mod:`.members` says)
ROLES = ("scalar", "label", "rgb")
PROJECTIONS = ("mip", "minip", "average")
#: where a label member's isosurface is: its visibility (0 or 1) reaching one half
LABEL_ISO = 0.5
#: points per piece where the converged reference looks for a label's boundaries (as for breakpoints)
LABEL_GRID = 64
RAYS_PER_BATCH = 2048


def several(scene) -> bool:
    """Whether the scene's data is several fields (a :class:`~dvr_gl.fields.layers.FieldSet`)."""
    return getattr(scene.field, "kind", None) == "fields"


def check(scene) -> None:
    """Refuse, in one line, a scene of several fields the references cannot render as the contract says."""
    if not several(scene):
        return
    r = scene.renderer
    for layer in scene.layers:
        name = layer.name or getattr(layer.field, "name", "") or layer.role
        if r.compositing in PROJECTIONS and layer.role != "scalar":
            raise SceneError(f"{name}: renderer.compositing = {r.compositing} projects each scalar field; a "
                             f"{layer.role} field has no value to project: use emission_absorption or isosurface")
        if layer.role != "scalar" and is_2d(layer.transfer_function):
            raise SceneError(f"{name}: " + ("a label field is classified by its label table" if layer.role == "label"
                                            else "an rgb field is classified by its data's colour and a 1D "
                                                 "transfer function of its luminance")
                             + ", not by a 2D transfer function of value and gradient magnitude: give it "
                             + ("a label table" if layer.role == "label" else "a 1D transfer function"))
        if layer.role != "scalar" and getattr(r, "hemispherical_shading", False):
            raise SceneError(f"{name}: hemispherical shading shades a transfer function's emission over a scalar "
                             f"grid, and a {layer.role} field's is its data's or its table's: turn "
                             f"renderer.hemispherical_shading off")
    scattering = getattr(r, "scattering", None)
    if scattering is not None and scattering.enabled:
        raise SceneError("several fields: the CPU references do not light the mixture by scattering; set "
                         "renderer.scattering.enabled = false or render one field")


class MemberOptics:
    """One member: its model (:func:`.members.optics`, its role's) and its box (closed, widened by 1e-9 of the
    box to absorb the rounding of points computed on its faces)."""

    def __init__(self, scene, layer, exact: bool, segment_length: float | None, transform=None):
        self.layer = layer
        self.label = layer.role == "label"
        self.iso = LABEL_ISO if self.label else layer.iso_value
        self.transform = transform  # (A, b): shared frame -> the member's own frame; None: the identity
        self.scene = member_scene(scene, layer, transform)
        self.model = optics(self.scene, layer, exact, segment_length)
        lo, hi = (np.asarray(b, np.float64) for b in layer.field.box)
        slack = 1e-9 * float(np.max(hi - lo) + max(layer.field.spacing))
        self.box = (lo, hi)  # in the member's own frame
        self.lo, self.hi = lo - slack, hi + slack

    def own(self, points: np.ndarray) -> np.ndarray:
        """Shared-frame points in the member's own frame (where its box is axis-aligned)."""
        if self.transform is None:
            return points
        a, b = self.transform
        return points @ a.T + b

    def inside(self, points: np.ndarray) -> np.ndarray:
        q = self.own(points)
        return np.all((q >= self.lo) & (q <= self.hi), axis=1)

    def chord(self, origins, directions, t0, t1) -> tuple[np.ndarray, np.ndarray]:
        """Each ray's parameters ``[a, b]`` inside the box, within ``[t0, t1]`` (``b <= a``: none); an oriented
        member's: the ray mapped into its frame (rigidly: the parameters are kept) meets its box there."""
        if self.transform is not None:
            origins, directions = self.own(origins), directions @ self.transform[0].T
        a, b = intersect_box(origins, directions, *self.box)
        return np.maximum(a, t0), np.minimum(b, t1)


def mean_colour(emitted: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """``sigma c / sigma``, 0 where nothing absorbs."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(sigma[:, None] > 0, emitted / sigma[:, None], 0.0)


def opacity_ratio(tau: np.ndarray) -> np.ndarray:
    """``g(tau) = tau / (1 - exp(-tau))``, 1 at ``tau = 0`` (its limit), by ``expm1``."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(tau > 1e-300, tau / -np.expm1(-np.maximum(tau, 1e-300)), 1.0)


class Mixture:
    """The optical model of several fields: what the references call on a single field's
    :class:`OpticalModel` (emission, the X-ray's emission, pre-integrated segments), mixed over the members.

    Args:
        scene: a resolved scene whose field is a :class:`~dvr_gl.fields.layers.FieldSet`.
        exact, segment_length: as :class:`OpticalModel`'s, for every member.
    """

    def __init__(self, scene, exact: bool = False, segment_length: float | None = None):
        check(scene)
        transforms = scene.field.transforms
        self.members = [MemberOptics(scene, layer, exact, segment_length, t)
                        for layer, t in zip(scene.layers, transforms)]
        # every member with a table has one (one setting); a label has none (its segments as post-classified)
        self.preintegration = next((m.model.preintegration for m in self.members
                                    if m.model.preintegration is not None), None)
        if any(m.model.depth_cue is not None for m in self.members):  # the cue spans the union box, as the rays
            cue = depth_cue(scene)
            for m in self.members:
                m.model.depth_cue = cue

    def _mixed(self, points, *arguments, call):
        """``(sum_i sigma_i c_i, sum_i sigma_i)`` of ``call(member, points, *arguments)``, which gives member
        i's ``(sigma_i c_i, sigma_i)`` at the points (and arguments) inside its box."""
        emitted = np.zeros((len(points), 3))
        sigma = np.zeros(len(points))
        for m in self.members:
            inside = m.inside(points)
            if inside.all():  # channels of one grid: no copies
                e, s = call(m, points, *arguments)
                emitted += e
                sigma += s
            elif inside.any():
                e, s = call(m, points[inside], *(a[inside] for a in arguments))
                emitted[inside] += e
                sigma[inside] += s
        return emitted, sigma

    def emission(self, points: np.ndarray, directions: np.ndarray, cells=None):
        """``(colour (N, 3), sigma (N,))``: the extinction-weighted mean of the members' shaded colours."""
        def member(m, p, d):
            colour, sigma = m.model.emission(p, d)
            return colour * sigma[:, None], sigma
        emitted, sigma = self._mixed(points, directions, call=member)
        return mean_colour(emitted, sigma), sigma

    def xray_emission(self, points: np.ndarray, directions: np.ndarray, cells=None):
        """``(sigma c (N, 3), sigma (N,))`` of the X-ray: the members' emissions and extinctions summed."""
        return self._mixed(points, directions, call=lambda m, p, d: m.model.xray_emission(p, d))

    def preintegrated(self, front, back, middle, directions, fraction):
        """Associated colour and optical depth of segments: each member's table where the segment's sample
        (``middle``) lies in its box, mixed by ``C = sum_i C_i g(tau_i) / g(tau)`` (see the module doc)."""
        def member(m, f, b, mid, d, frac):
            premult, tau = m.model.preintegrated(f, b, mid, d, frac)
            return premult * opacity_ratio(tau)[:, None], tau
        weighted, tau = self._mixed(middle, front, back, middle, directions, fraction,
                                    call=lambda m, mid, *rest: member(m, *rest))
        return weighted / opacity_ratio(tau)[:, None], tau


# --- the same-discretization reference's per-channel modes ------------------------------------------------

def project(ref, mode: str) -> np.ndarray:
    """Per-channel MIP, MinIP or average of :class:`~dvr_gl.reference.discrete.DiscreteReference` ``ref``
    over the union's segments: each member over its samples inside its box, then mixed (module doc)."""
    n = len(ref.rays)
    members = ref.model.members
    start = {"average": 0.0, "mip": -np.inf, "minip": np.inf}[mode]
    acc = np.full((len(members), n), start)
    length = np.zeros((len(members), n))
    seen = np.zeros((len(members), n), bool)
    for rows, k, m in ref._steps(ref.n_seg > 0):
        grid = ref.plan.grid(rows, k, m)
        for i, member in enumerate(members):
            inside = member.inside(grid.points)
            if not inside.any():
                continue
            s = np.full(len(inside), start)
            s[inside] = member.model.scalar.sample(grid.points[inside])
            into = grid.scatter(inside, False)
            seen[i, rows] |= into.any(axis=1)
            if mode == "average":
                acc[i, rows] += np.sum(grid.scatter(s) * grid.length, axis=1)
                length[i, rows] += np.sum(np.where(into, grid.length, 0.0), axis=1)
            elif mode == "mip":
                acc[i, rows] = np.maximum(acc[i, rows], grid.scatter(s, -np.inf).max(axis=1))
            else:
                acc[i, rows] = np.minimum(acc[i, rows], grid.scatter(s, np.inf).min(axis=1))
        ref.samples += int(grid.valid.sum())
    if mode == "average":
        acc = acc / np.where(length > 0, length, 1.0)
    return combine_projections([m.model for m in members], acc, seen)


def combine_projections(models, values: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """Each member's projected ``values[i]`` (where ``seen[i]``) classified by its own model; the pixel's
    premultiplied colour ``sum_i a_i c_i``, alpha ``1 - prod_i (1 - a_i)``."""
    rgba = np.zeros((values.shape[1], 4))
    clear = np.ones(values.shape[1])
    for model, v, has in zip(models, values, seen):
        colour, alpha = model.classify_value(v[has])
        rgba[has, :3] += colour * alpha[:, None]
        clear[has] *= 1.0 - alpha
    rgba[:, 3] = 1.0 - clear
    return rgba


def first_hit(ref) -> np.ndarray:
    """The isosurface of :class:`~dvr_gl.reference.discrete.DiscreteReference` ``ref`` on several fields: the
    first of the entry point and the samples where any member reaches its iso-value (inside its box), bisection
    on that member alone, its colour at its iso-value, shaded by its gradient, opaque."""
    members = ref.model.members
    n = len(ref.rays)
    isos = np.array([m.iso for m in members])
    has = ref.n_seg > 0
    entry = ref.rays.points(np.arange(n), ref.rays.t0[:, None])
    prev_s = np.stack([_values(m, entry) for m in members])  # (members, rays); -inf outside a box
    prev_t = ref.rays.t0.copy()
    above = prev_s >= isos[:, None]
    hit = has & above.any(axis=0)
    which = np.where(hit, np.argmax(above, axis=0), -1)
    bracket = np.zeros((n, 4))  # t_a, s_a, t_b, s_b of the member hit, s_a < iso <= s_b
    rows = np.nonzero(hit)[0]
    s_hit = prev_s[which[rows], rows]
    bracket[rows] = np.stack([prev_t[rows], s_hit, prev_t[rows], s_hit], axis=1)
    active = has & ~hit
    for rows, k, m in ref._steps(active):
        grid = ref.plan.grid(rows, k, m)
        s = np.stack([grid.scatter(_values(member, grid.points), fill=-np.inf) for member in members])
        up = grid.valid[None] & (s >= isos[:, None, None])  # (members, rows, m)
        first = np.where(up.any(axis=2), np.argmax(up, axis=2), m)  # each member's first sample
        j = first.min(axis=0)
        found = j < m
        ref.samples += int(np.where(found, j + 1, grid.valid.sum(axis=1)).sum())
        member = np.argmax(first == j[None], axis=0)  # the first member listed at that sample
        fr, jf, mf = rows[found], j[found], member[found]
        idx = np.nonzero(found)[0]
        t_b, s_b = grid.t[idx, jf], s[mf, idx, jf]
        t_a = np.where(jf > 0, grid.t[idx, np.maximum(jf - 1, 0)], prev_t[fr])
        s_a = np.where(jf > 0, s[mf, idx, np.maximum(jf - 1, 0)], prev_s[mf, fr])
        bracket[fr] = np.stack([t_a, s_a, t_b, s_b], axis=1)
        which[fr] = mf
        hit[fr] = True
        active[fr] = False
        last = np.maximum(grid.valid.sum(axis=1) - 1, 0)
        prev_t[rows] = grid.t[np.arange(len(rows)), last]
        prev_s[:, rows] = s[:, np.arange(len(rows)), last]
    rgba = np.zeros((n, 4))
    for i, member in enumerate(members):
        rows = np.nonzero(hit & (which == i))[0]
        if not len(rows):
            continue
        t, t_b = _refine(ref.rays, member, rows, bracket[rows], isos[i], ref.scene.renderer.iso_refinement)
        directions = ref.rays.directions[rows]
        if member.label:  # the label on the bracket's visible side, shaded by its indicator
            colour = member.model.hit_colour(ref.rays.points(rows, t_b[:, None]), directions)
        elif member.layer.role == "rgb":  # the data's colour where x reaches the iso-value
            colour = member.model.hit_colour(ref.rays.points(rows, t[:, None]), directions)
        else:
            colour, _ = member.model.classify_value(np.full(len(rows), isos[i]))
            if member.model.shading is not None:
                colour = member.model.shade(colour, ref.rays.points(rows, t[:, None]), directions)
        rgba[rows, :3] = colour
        rgba[rows, 3] = 1.0
    return rgba


def _values(member: MemberOptics, points: np.ndarray) -> np.ndarray:
    """What the member's isosurface is a level of at points: its scalar, a label's visibility (0 or 1);
    ``-inf`` outside its box (no hit there)."""
    out = np.full(len(points), -np.inf)
    inside = member.inside(points)
    sample = member.model.visible if member.label else member.model.scalar.sample
    out[inside] = sample(points[inside])
    return out


def _refine(rays, member, rows, bracket, iso, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Bisection on ``[t_a, t_b]`` keeping ``s(t_a) < iso <= s(t_b)`` on the member alone, then linear
    interpolation (to ``t_b`` where ``s(t_a)`` lies outside the box: the hit is on its face): ``(t, t_b)``."""
    t_a, s_a, t_b, s_b = bracket.T.copy()
    for _ in range(steps):
        t_m = 0.5 * (t_a + t_b)
        s_m = _values(member, rays.points(rows, t_m[:, None]))
        up = s_m >= iso
        t_b, s_b = np.where(up, t_m, t_b), np.where(up, s_m, s_b)
        t_a, s_a = np.where(up, t_a, t_m), np.where(up, s_a, s_m)
    span = s_b - s_a
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where((span > 0) & np.isfinite(span), (iso - s_a) / span, 1.0)
    return t_a + np.clip(w, 0.0, 1.0) * (t_b - t_a), t_b


# --- the converged reference -------------------------------------------------------------------------------

def mixture_pieces(mixture: Mixture, rays, rows: np.ndarray):
    """Pieces ``(ray, a, b, cell)`` of rays ``rows`` on which every member is smooth, sorted along each ray: cut
    where a ray enters and leaves a member's box (the mixture jumps there) and at each member's filter knots
    inside its box (:meth:`~dvr_gl.fields.reconstruction.SampledField.knots`); ``cell`` 0 (grids)."""
    o, d, t0, t1 = rays.origins[rows], rays.directions[rows], rays.t0[rows], rays.t1[rows]
    every = np.arange(len(rows))
    local, ts = [every, every], [t0, t1]
    for m in mixture.members:
        a, b = m.chord(o, d, t0, t1)
        idx = np.nonzero(b > a)[0]
        k_ray, k_t = m.model.scalar.knots(o[idx], d[idx], a[idx], b[idx])
        local += [idx, idx, idx[k_ray]]
        ts += [a[idx], b[idx], k_t]
    local, t = np.concatenate(local), np.concatenate(ts)
    order = np.lexsort((t, local))
    local, t = local[order], t[order]
    keep = (local[1:] == local[:-1]) & (t[1:] > t[:-1])
    return rows[local[:-1][keep]], t[:-1][keep], t[1:][keep], np.zeros(int(keep.sum()), np.int64)


def mixture_cuts(ref, ray, a, b, cell):
    """Where a member's field crosses one of its transfer function's breakpoints inside a piece that lies in its
    box (as :meth:`~dvr_gl.reference.converged.ConvergedReference._breakpoint_cuts` for one field), or a label
    member's label changes (:func:`label_cuts`): ``(piece, t)``, or None."""
    middle = ref.rays.origins[ray] + (0.5 * (a + b))[:, None] * ref.rays.directions[ray]
    pieces, ts = [], []
    for m in ref.model.members:
        inside = np.nonzero(m.inside(middle))[0]
        if not len(inside):
            continue
        if m.label:
            found = label_cuts(ref.rays, m, ray[inside], a[inside], b[inside])
        else:
            found = ref._breakpoint_cuts(ray[inside], a[inside], b[inside], cell[inside], m.model)
        if found is not None:
            pieces.append(inside[found[0]])
            ts.append(found[1])
    return (np.concatenate(pieces), np.concatenate(ts)) if pieces else None


def label_cuts(rays, member, ray, a, b):
    """Where a label member's label changes inside pieces ``[a, b]`` of rays ``ray``, ``(piece, t)`` or None: the
    sample's colour and extinction jump there.  Found as the breakpoints are: changes between
    :data:`LABEL_GRID` + 1 points per piece, then bisection to float64 resolution (a label region thinner
    than 1/64 of a piece could be missed)."""
    grid = np.linspace(0.0, 1.0, LABEL_GRID + 1)
    t = a[:, None] + (b - a)[:, None] * grid[None, :]

    def labels(ray_, t_):
        points = rays.origins[ray_, None, :] + t_[..., None] * rays.directions[ray_, None, :]
        return member.model.labels(points.reshape(-1, 3))[0].reshape(t_.shape)
    along = labels(ray, t)
    piece, j = np.nonzero(along[:, 1:] != along[:, :-1])
    if not len(piece):
        return None
    lo, hi, left = t[piece, j], t[piece, j + 1], along[piece, j]
    for _ in range(60):
        m = 0.5 * (lo + hi)
        same = labels(ray[piece], m[:, None])[:, 0] == left
        lo, hi = np.where(same, m, lo), np.where(same, hi, m)
    return piece, 0.5 * (lo + hi)


def label_first_hit(ref, member) -> tuple[np.ndarray, np.ndarray]:
    """A label member's isosurface in the converged reference: per ray, ``(t, rgba)`` of the first point of
    its chord where the label is visible (``t`` inf where none), exact to float64 resolution: pieces between
    the cells' faces cut where the label changes (:func:`label_cuts`) hold one label each."""
    rays = ref.rays
    n = len(rays)
    hit_t, rgba = np.full(n, np.inf), np.zeros((n, 4))
    todo = np.nonzero(rays.t1 > rays.t0)[0]
    for start in range(0, len(todo), RAYS_PER_BATCH):
        rows = todo[start:start + RAYS_PER_BATCH]
        o, d = rays.origins[rows], rays.directions[rows]
        a, b = member.chord(o, d, rays.t0[rows], rays.t1[rows])
        local, pa, pb = smooth_pieces(member.model.scalar, o, d, a, b)
        ray, cell = rows[local], np.zeros(len(local), np.int64)
        cuts = label_cuts(rays, member, ray, pa, pb) if len(ray) else None
        if cuts is not None:
            ray, pa, pb, cell = ref._split(ray, pa, pb, cell, *cuts)
        middle = rays.origins[ray] + (0.5 * (pa + pb))[:, None] * rays.directions[ray]
        visible = np.nonzero(member.model.visible(middle) > 0)[0]
        first = np.full(n, len(ray))
        np.minimum.at(first, ray[visible], visible)  # pieces are sorted along each ray
        hit = np.nonzero(first < len(ray))[0]
        p = first[hit]
        hit_t[hit] = pa[p]
        # the colour just inside the piece: its label, shaded by that label's indicator at the boundary
        inside = rays.origins[hit] + (pa[p] + 1e-9 * (pb[p] - pa[p]))[:, None] * rays.directions[hit]
        rgba[hit, :3] = member.model.hit_colour(inside, rays.directions[hit])
        rgba[hit, 3] = 1.0
    return hit_t, rgba


def per_channel(ref) -> np.ndarray:
    """The converged reference's per-channel modes (``(N, 4)`` per ray, before surfaces): each member's own
    converged image over its chord of its box (exact in its own model), mixed: MIP, MinIP and average
    additively (:func:`combine_projections`), the isosurface by the nearest first hit (ties: the member listed
    first)."""
    mode = ref.scene.renderer.compositing
    members = ref.model.members
    n = len(ref.rays)
    rgba = np.zeros((len(members), n, 4))
    hit_t = np.full((len(members), n), np.inf)
    for i, m in enumerate(members):
        if m.label:  # isosurface only (check)
            hit_t[i], rgba[i] = label_first_hit(ref, m)
            continue
        sub = type(ref)(m.scene, nodes=len(ref.x))
        if m.transform is not None:  # its rays over the oriented box's chord, not its bounding box's
            rays = sub.rays
            rays.t0, rays.t1 = m.chord(rays.origins, rays.directions, rays.t0, rays.t1)
            rays.t1 = np.where(rays.t1 > rays.t0, rays.t1, rays.t0)
        sub.model = m.model  # its role's (an rgb member's reads x), the depth cue over the union box
        if ref.progress is not None:
            sub.progress = lambda done, total, i=i: ref.progress(i * total + done, len(members) * total)
        rgba[i] = sub.volume_rgba()
        hit_t[i] = sub.hit_t
        if m.layer.role == "rgb" and mode == "isosurface":  # the data's colour at the hit
            rows = np.nonzero(np.isfinite(sub.hit_t))[0]
            points = ref.rays.origins[rows] + sub.hit_t[rows, None] * ref.rays.directions[rows]
            rgba[i, rows, :3] = m.model.hit_colour(points, ref.rays.directions[rows])
        for key in ("pieces", "evaluations"):
            ref.stats[key] += sub.stats[key]
        ref.stats["converged"] &= sub.stats["converged"]
    if mode == "isosurface":
        ref.hit_t = hit_t.min(axis=0)
        which = np.argmin(hit_t, axis=0)
        return np.where(np.isfinite(hit_t.min(axis=0))[:, None], rgba[which, np.arange(n)], 0.0)
    out = np.zeros((n, 4))
    out[:, :3] = rgba[..., :3].sum(axis=0)
    out[:, 3] = 1.0 - np.prod(1.0 - rgba[..., 3], axis=0)
    return out
