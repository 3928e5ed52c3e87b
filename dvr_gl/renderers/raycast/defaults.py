"""The ray caster's defaults chosen by the scene: sample distance, classification and early termination
for an image error an 8-bit display does not show (docs/tolerance.md, "Defaults").

When a scene gives no sample distance and no tolerance, :func:`resolve_defaults` (called from the
ray caster's ``resolve`` hook) chooses them from the scene itself.  The error is *simulated* on the
random lines of :func:`.tolerance.line_samples` (192 lines through the box, 8 samples per voxel, the
scene's filter and exact transfer function): each line is composited as the ray caster would
composite it at a sample distance ``d`` (every ``k``-th fine sample, ``d = k / 8`` voxel, from a
random first sample), and the same line at the fine step is its reference.  The RMS of the
difference over the lines (premultiplied RGBA, the four channels) estimates the RMS error over the
pixels the volume covers (emission-absorption: over the lines that meet the transfer function's content,
the pixels that show the volume, :func:`visible_lines`); the largest distance of :data:`LADDER` whose
estimate is at most ``MARGIN * TARGET`` is chosen, for each classification the scene allows, and the cheaper one kept.
Emission-absorption is never less accurate on the lines than one sample a voxel, post-classified (the classic
default, the peers'): where that is more accurate than the display target asks (or the target is out of reach),
the cheapest choice no less accurate than it is taken (:func:`classic_choice`; docs/tolerance.md, "Never less
accurate than one sample a voxel").

* emission-absorption, post-classified: the classified samples' opacities ``1 - exp(-sigma d)``
  composited front to back;
* pre-integrated: each segment integrated exactly over the data linear between its two samples (the
  fine samples of that line), which is what the pre-integration table holds;
* MIP and MinIP: the extremum of the line's samples at ``d``, refined between the samples by
  :data:`EXTREMUM_REFINEMENT` parabolic steps (:func:`dvr_gl.reference.discrete.refine_extremum`, what
  the shader does) in :data:`EXTREMUM_BRACKETS` brackets (the extreme sample's and the best peak's not
  next to it, :class:`dvr_gl.reference.discrete.SecondCandidates`), against the fine samples' extremum
  refined the same way, each classified once (colour and the opacity of one unit distance): the error of
  the maximum along a ray of a trilinear field sampled every ``d``.  Their target is :data:`MIP_TARGET`.

Early termination drops at most ``1 - threshold`` of a ray's colour: ``TARGET / 4``.  Scenes the
simulation does not model (shading, gradient opacity, scattering, jitter, other compositing modes,
several fields) keep the fixed default, :data:`~dvr_gl.scene.settings.DEFAULT_SAMPLE_DISTANCE_VOXELS`.
The choice depends only on the field, the transfer function and the renderer's model settings, and
is cached in :data:`CACHE` under their identities (a second scene of the same data costs a lookup).
"""

from __future__ import annotations

import dataclasses
import hashlib
import time
import weakref
from dataclasses import dataclass

import numpy as np

from ...errors import SceneError
from ...fields import diagonal, reconstruct
from ...reference.discrete import refine_extremum
from ...scene.settings import DEFAULT_SAMPLE_DISTANCE_VOXELS
from ...transfer_function_2d import is_2d
from . import PLUGIN, tolerance
from .tolerance import apply, check_tolerance, sampling_model  # noqa: F401  the error model beside the hook

#: The defaults' target: RMS error (premultiplied linear RGBA, against the converged reference) of one
#: 8-bit display step, 1/255 (48.1 dB).  Most pixels then differ from the converged image by less than
#: one display level, the step 8-bit output quantizes to anyway; docs/tolerance.md, "Defaults".
TARGET = 1.0 / 255.0
#: MIP and MinIP's target, half a display step (0.5/255, 54.2 dB).  A projection's error is not spread over
#: the image as a composite's is: a ray's whole value comes from one point, so a missed peak shows as a
#: pixel off by many steps, and the peers' refined MIPs reach it (vispy's, which samples again around its
#: largest sample: 0.34/255 on mri-mip).  With two brackets refined the ray caster meets it at a step
#: longer than the peers' one sample per voxel on the five MIP scenes of ``dvr bench peers``
#: (docs/peers.md, "A second bracket and a MIP target").
MIP_TARGET = 0.5 / 255.0
#: The simulated RMS (over the lines, which cross the volume) must be at most this fraction of the
#: target: on the peers' scenes it measured 0.9-1.5x the whole image's RMS (docs/tolerance.md).
MARGIN = 1.0
#: The lines' fine steps per voxel: their composite is the reference of the simulation.
PER_VOXEL = 4
#: Sample distances tried, in voxels: an odd number of fine steps each, so that each segment's middle
#: is a fine sample (largest first).  At most 2.75: 128 lines can miss a small feature altogether, and a
#: step below 3 voxels cannot step over a feature 3 voxels thick.
LADDER = (2.75, 2.25, 1.75, 1.25, 0.75)
#: Pre-integration is taken only where it meets the target at this many times post-classification's
#: distance: its samples cost 1.15x (:data:`.tolerance.PREINTEGRATED_COST`), but a pre-integrated frame
#: jumps only empty blocks, not constant ones (measured on the Shepp-Logan scene of dvr bench peers:
#: pre-integrated at 0.75 voxel took 1.7x post-classified at 0.75, 1.2x post at 0.5 voxel).
PREINTEGRATED_GAIN = 2.0
#: Where even the finest of the ladder misses the target: the fixed default's distance.
FINEST = DEFAULT_SAMPLE_DISTANCE_VOXELS
#: Emission-absorption: where even :data:`FINEST` misses the target by more than this factor on the lines, the
#: target is out of reach: halving the step again (twice the finest's cost) at best quarters the error (second
#: order), and the finest's frame would pay for an error the display still shows.  The defaults then take the
#: cheapest choice whose simulated error is no worse than one sample a voxel, post-classified (the classic
#: default, the peers'), at most one voxel apart (pre-integrated: two), so that what a step of one voxel shows is
#: not stepped over (a spike of 1e-4 of the range vanished at 2.75 voxel): the buckyball's narrow shell (32^3, a
#: 20-unit tent) missed the target by 17.5x at 0.5 voxel and took 63 ms for 28.5 dB, where pre-integrated 1.75
#: voxel gives 25.4 dB (one voxel: 23.6) in 0.4x the time (docs/tolerance.md, "A target out of reach").  The same
#: choice (:func:`classic_choice`) is taken where one sample a voxel is more accurate than the target asks: the
#: defaults are never less accurate on the lines than the classic default (on seven of the peers' scenes its image
#: was 2.3-20 dB closer to the converged one than the display target's choice, for up to 1.8x its frame, and
#: 1.6-3.4x faster than VTK GPU and 2.7-5.5x than vispy at better error than both; docs/tolerance.md, "Never less
#: accurate than one sample a voxel").
OUT_OF_REACH = 4.0
#: Emission-absorption: the display target's choice counts as less accurate than one sample a voxel where its simulated
#: error exceeds that one's by more than this fraction of the target (1 % of a display step: no picture shows it;
#: it keeps rounding noise, errors of 1e-16, from deciding).
CLASSIC_SLACK = 0.01
#: Compositing modes the simulation covers.
MODES = ("emission_absorption", "mip", "minip")
#: Choices made, by what they depend on: ``{key: DefaultChoice}`` (see :func:`cache_key`).
CACHE: dict = {}
CACHE_SIZE = 32
#: MIP and MinIP: the parabolic steps refining each ray's extremum between its samples where the scene gives
#: none (renderer.extremum_refinement; 8 texture fetches a ray with the bracket's two, against hundreds of
#: samples).  On mri-mip's lines (docs/tolerance.md) the simulated error at 1.75 voxel fell from 4.0/255
#: unrefined to 1.35, 0.97, 0.72 and 0.64/255 with 1, 2, 3 and 6 steps; its image at 1 voxel from 48.6 dB
#: unrefined to 51.9, 53.8, 56.7, 58.1, 58.9 and 59.1 dB with 1, 2, 3, 4, 6 and 8 steps.
EXTREMUM_REFINEMENT = 6
#: MIP and MinIP where the scene gives no renderer.extremum_refinement: the step counts simulated, each at the
#: largest distance of the ladder meeting the target; the cheapest per ray (:func:`ray_cost`) is kept.  Fewer
#: steps often need a shorter distance (mri-mip: 4 steps meet the target at 0.75 voxel, 6 at 1.25), but not
#: always (brain-mip: both at 1.25 voxel, 4 steps 7 % faster; docs/peers.md, "A cheaper refined MIP").
REFINEMENT_CHOICES = (4, EXTREMUM_REFINEMENT)
#: What one refinement fetch (a bracket's end or a parabolic step) costs, in samples of the ray's loop: on
#: brain-mip at 1.25 voxel (llvmpipe, 2026-11-28) one bracket's 8 fetches took 18 % of the unrefined frame
#: of about 75 samples a ray, the 6 steps of two brackets 12 %: about 1.7-2 samples each.  Since the refinement
#: fetches from one call site in a loop and the frame is scissored to the volume's pixels (2026-11-29), measured
#: again at 512x512 against the loop's counted samples: 1.0-1.2 on the chromosomes' slab at 1.25 voxel, 1.7-2.2 on
#: brain-mip, 1.7-2.5 on mri-mip, 2.6-2.7 on the spindle slab at 2.25 voxel (docs/peers.md, "A cheaper
#: refinement"): 2 kept.
REFINE_FETCH_COST = 2.0
#: MIP and MinIP: the brackets refined where the scene gives none (renderer.extremum_brackets): the extreme
#: sample's and the best peak's of the samples not next to it (a second peak, whose field may rise above the extreme
#: sample's between the samples).  On 3000 lines through MNI152 at 1.25 voxel, refining the second too
#: took the value's RMS error from 0.56/255 to 0.35/255 (below one bracket at 1 voxel, 0.57/255) for 8
#: more texture fetches a ray (docs/peers.md, "Refining more than one bracket").
EXTREMUM_BRACKETS = 2
#: MIP and MinIP where the scene gives no renderer.extremum_brackets: the brackets simulated with each of
#: :data:`REFINEMENT_CHOICES`; the cheapest per ray (:func:`ray_cost`) is kept.  The second bracket lets the
#: distance grow where a second peak lies between the samples (MNI152), but costs its fetches and the loop's
#: tracking of the second candidate: on the held-out scenes nucleon, ironProt and the confocal DNA channel the
#: frame at the same distance took 1.28-1.39x one bracket's (512x512, interleaved, 2026-11-29), about what
#: :func:`ray_cost` makes of it (ironProt at 1.25 voxel: 1.29x), and one bracket met the target at a distance
#: as long or nearly (docs/tolerance.md, "One bracket or two").
BRACKET_CHOICES = (1, EXTREMUM_BRACKETS)
#: MIP and MinIP: choices whose :func:`ray_cost` is within this fraction of the cheapest are level, and the one
#: with more brackets is kept.  The model prices a refinement fetch at a fixed 2 samples (measured 1.7-2) and frames
#: of one setting scatter by 5-10 % between interleaved runs here, so 10 % cheaper in the model is not reliably
#: faster; and the second bracket catches the rare ray whose second peak rises above the extreme sample, the heavy
#: tail that 512 lines sample worst.  brain-mip: one bracket of 6 steps at 1.25 voxel modelled 0.92x two of 4, timed
#: 0.94x, simulated 0.47/255 against 0.44/255, but its image was at 52.9 dB against 54.2 (with R8 textures).
COST_TIE = 0.10
#: Random lines simulated (:func:`.tolerance.line_samples`).
LINES = 128
#: MIP and MinIP: lines simulated.  A projection's error comes from the few lines whose peak falls between
#: the samples (a heavy tail), so 128 lines scatter: on mri-mip with two brackets at 1.75 voxel they gave
#: 0.42/255, 512 lines 0.55 and 1024 lines 0.92 (the image: 0.39).  512 cost 0.1-0.3 s, once per field.
MIP_LINES = 512
#: At most this many fine steps along a line (a box this many quarter voxels across keeps the fixed
#: default: its lines would cost more than the choice saves).
MAX_STEPS = 16384


@dataclass(frozen=True)
class DefaultChoice:
    """What :func:`choose_defaults` picked: the settings and the simulated RMS error at them."""

    classification: str
    sample_distance_voxels: float
    ert_threshold: float
    estimated_error: float
    seconds: float   # what choosing took (the lines and the simulation)
    extremum_refinement: int | None = None  # MIP and MinIP: the parabolic steps simulated (else None)
    extremum_brackets: int | None = None  # MIP and MinIP with refinement: the brackets simulated (else None)
    classic_target: float | None = None  # where it bounds the choice: the simulated error of one sample a voxel
    out_of_reach: bool = False  # the target out of reach (else, with a classic_target, looser than it)

    def renderer_changes(self, voxel: float) -> dict:
        changes = {"classification": self.classification, "sample_distance": self.sample_distance_voxels * voxel,
                   "ert_threshold": self.ert_threshold}
        if self.extremum_refinement is not None:
            changes["extremum_refinement"] = self.extremum_refinement
        if self.extremum_brackets is not None:
            changes["extremum_brackets"] = self.extremum_brackets
        return changes

    def describe(self, voxel: float = 1.0) -> str:
        refined = "" if self.extremum_refinement is None else \
            f", the extremum refined in {self.extremum_refinement} parabolic steps"
        if self.extremum_brackets == 2:
            refined += " in two brackets"
        target = TARGET if self.extremum_refinement is None else MIP_TARGET
        aim = f"target {target:.2g}"
        if self.classic_target is not None:
            why = f"out of reach at {FINEST:g} voxel" if self.out_of_reach else "looser than one sample a voxel"
            aim += f" {why}: one sample a voxel's {self.classic_target:.2g}"
        return (f"defaults chosen by the scene: {self.classification} classification, sample distance "
                f"{self.sample_distance_voxels:g} voxel{refined}, early termination at {self.ert_threshold:g}; "
                f"simulated RMS error {self.estimated_error:.2g} ({aim})")


def modelled(scene) -> bool:
    """Whether the simulation covers this scene (else the fixed default stays)."""
    r = scene.renderer
    if getattr(scene.field, "kind", None) != "grid" or r.compositing not in MODES:
        return False
    if getattr(scene.field, "out_of_core", False):  # the lines would read voxels that stay on disk
        return False
    if r.compositing == "emission_absorption" and (r.shading.enabled or r.gradient_opacity or r.scattering.enabled
                                                   or r.classification == "pre"):
        return False
    # a 2D transfer function (value and gradient) is not what the lines classify
    return not r.jitter and hasattr(scene.transfer_function, "points") and not is_2d(scene.transfer_function)


def cache_key(scene) -> tuple:
    """What the choice depends on: the field (its voxels' digest, geometry and type; an out-of-core
    field by identity), the transfer function's points and units, and the renderer settings that
    change the simulated signal."""
    tf, r = scene.transfer_function, scene.renderer
    points = np.asarray(tf.points, dtype=np.float64)
    return (field_key(scene.field), points.tobytes(), points.shape, tf.unit_distance, tf.opacity_model,
            r.compositing, r.filter, r.classification, r.preintegration_size, refinement_steps(scene),
            refinement_brackets(scene), getattr(r, "extremum_refinement", None), getattr(r, "extremum_brackets", None))


def field_key(field) -> tuple:
    """The field's part of :func:`cache_key`: its voxels' digest, geometry and type (an out-of-core field or
    one without voxels by identity: ``("object", id)``)."""
    data = None if getattr(field, "out_of_core", False) else getattr(field, "data", None)
    if isinstance(data, np.ndarray):
        return voxels_digest(data), data.shape, str(data.dtype), tuple(field.spacing), tuple(field.origin)
    return "object", id(field)


def refinement_steps(scene) -> int | None:
    """MIP and MinIP: the parabolic steps refining the extremum, the scene's own or
    :data:`EXTREMUM_REFINEMENT`; None for the other modes."""
    r = scene.renderer
    if r.compositing not in ("mip", "minip"):
        return None
    return EXTREMUM_REFINEMENT if r.extremum_refinement is None else r.extremum_refinement


def refinement_brackets(scene) -> int | None:
    """MIP and MinIP that refine the extremum: the brackets refined, the scene's own or
    :data:`EXTREMUM_BRACKETS`; None for the other modes and where nothing is refined."""
    if not refinement_steps(scene):
        return None
    own = scene.renderer.extremum_brackets
    return EXTREMUM_BRACKETS if own is None else own


def target_of(mode: str) -> float:
    """The defaults' RMS target for compositing ``mode``: :data:`MIP_TARGET` for MIP and MinIP, else
    :data:`TARGET`."""
    return MIP_TARGET if mode in ("mip", "minip") else TARGET


#: Digests of the voxels by array identity, ``{id: (weak reference, digest)}``: a scene changed again
#: (Scene.with_renderer, a new transfer function) looks its choice up without hashing its voxels again.
DIGESTS: dict = {}


def voxels_digest(data: np.ndarray) -> str:
    """A digest of ``data``'s bytes, computed once per array object (arrays are not changed in place
    once in a scene)."""
    known = DIGESTS.get(id(data))
    if known is not None and known[0]() is data:
        return known[1]
    digest = hashlib.blake2b(memoryview(np.ascontiguousarray(data)).cast("B"), digest_size=16).hexdigest()
    if len(DIGESTS) >= CACHE_SIZE:
        DIGESTS.pop(next(iter(DIGESTS)))
    DIGESTS[id(data)] = (weakref.ref(data), digest)
    return digest


def choose_defaults(scene) -> DefaultChoice:
    """The cached choice for ``scene`` (computed on the first call for its data, transfer function and
    mode; :func:`cache_key`)."""
    key = cache_key(scene)
    hit = CACHE.get(key)
    if hit is not None and (hit[0] is None or hit[0] is scene.field):
        return hit[1]
    choice = simulate_choice(scene)
    if len(CACHE) >= CACHE_SIZE:
        CACHE.pop(next(iter(CACHE)))
    # an entry keyed by an object's identity holds that object, so that its id is not reused
    CACHE[key] = (scene.field if key[0][0] == "object" else None, choice)
    return choice


@dataclass(frozen=True)
class Lines:
    """The simulated lines: ``start + t direction`` (world units), entering the box at ``t0``; ``value_at(rows,
    t)``: the scene's field there (the filter the renderer reconstructs with)."""

    start: np.ndarray
    direction: np.ndarray
    t0: np.ndarray
    reconstruction: object

    def value_at(self, t: np.ndarray) -> np.ndarray:
        """The field at parameter ``t`` (one per line)."""
        return self.reconstruction.sample(self.start + self.direction * t[:, None])


def box_lines(scene, count: int = LINES, per_voxel: int = PER_VOXEL, classify: bool = True):
    """The data along ``count`` random lines (:func:`.tolerance.random_lines`), inside the box only:
    ``(s, composed, n, step, lines)``: the values ``s`` (lines, m) at the middles of steps of ``step``
    world units from where each line enters the box (``n`` of them on each line; ``m`` the most), the
    classified ``(sigma, sigma r, sigma g, sigma b)`` (lines, m, 4), zero past ``n`` (None unless
    ``classify``: MIP and MinIP classify only each line's extremum), and the :class:`Lines` themselves.
    The sampled data is kept per field and filter (:data:`SAMPLED`): a new transfer function or mode on the
    same data classifies them again without sampling again."""
    key = (field_key(scene.field), scene.renderer.filter, count, per_voxel)
    hit = SAMPLED.get(key)
    if hit is None or (hit[0] is not None and hit[0] is not scene.field):
        hit = (scene.field if key[0][0] == "object" else None, sampled_lines(scene, count, per_voxel))
        if len(SAMPLED) >= SAMPLED_SIZE:
            SAMPLED.pop(next(iter(SAMPLED)))
        SAMPLED[key] = hit
    s, live, n, step, lines = hit[1]
    return s, classified(s, live, scene.transfer_function) if classify else None, n, step, lines


#: The lines' samples by field and filter, ``{key: (field or None, sampled_lines(...))}`` (about 2 MB each).
SAMPLED: dict = {}
SAMPLED_SIZE = 4


def sampled_lines(scene, count: int, per_voxel: int):
    """:func:`box_lines`' data before classification: ``(s, live, n, step, lines)``."""
    start, direction, _ = tolerance.random_lines(scene.field, count)
    return sampled_along(scene, start, direction, per_voxel)


def sampled_along(scene, start, direction, per_voxel: int):
    """The field's values along the lines ``start + t direction`` inside the box, at the middles of steps
    of ``1 / per_voxel`` voxel from where each enters it: ``(s, live, n, step, lines)`` as
    :func:`sampled_lines`."""
    from ...rays import intersect_box

    field = scene.field
    t0, t1 = intersect_box(start, direction, *field.bounds)
    step = field.sample_spacing / per_voxel
    n = np.where(t1 > t0, np.floor((t1 - t0) / step), 0).astype(np.int64)
    m = int(n.max(initial=0))
    live = np.arange(m)[None, :] < n[:, None]
    reconstruction = reconstruct(field, scene.renderer)
    s = np.empty(live.shape)
    rows = max(1, LINE_CHUNK // max(m, 1))  # lines a chunk: its points stay in the cache
    for i in range(0, len(n), rows):
        block = slice(i, i + rows)
        # past a line's end its entry point is sampled again (the box's, so a valid point; not live)
        t = np.where(live[block], t0[block, None] + (np.arange(m)[None, :] + 0.5) * step, t0[block, None])
        points = start[block, None, :] + direction[block, None, :] * t[..., None]
        s[block] = reconstruction.sample(points.reshape(-1, 3)).reshape(t.shape)
    return s, live, n, step, Lines(start, direction, t0, reconstruction)


#: Fine samples a chunk of :func:`sampled_along` (its points, 24 bytes each, stay in the cache).
LINE_CHUNK = 1 << 16


def visible_lines(scene, s, composed, n):
    """Emission-absorption: the lines that meet the transfer function's content (a sample of non-zero
    extinction; the pixels that show the volume), with more drawn through the content where fewer than
    :data:`CONTENT_LINES` of the uniform ones do (:func:`content_lines`): ``(s, composed, n)``.  Lines that
    meet nothing have no error, so counting them would dilute the error of the pixels that show something:
    on the hydrogen atom's narrow shell 5 of 128 uniform lines met it, and the image missed the target by
    1.2x (docs/peers.md).  Unchanged where there is no content."""
    crossing = composed[..., 0].max(axis=1, initial=0.0) > 0.0
    missing = CONTENT_LINES - int(crossing.sum())
    extra = content_lines(scene, missing) if missing > 0 else None
    if not crossing.any() and extra is None:
        return s, composed, n
    s, composed, n = s[crossing], composed[crossing], n[crossing]
    if extra is None:
        return s, composed, n
    es, live, en = extra[0], extra[1], extra[2]
    ecomposed = classified(es, live, scene.transfer_function)
    m = max(s.shape[1], es.shape[1])
    pad = lambda a: np.pad(a, [(0, 0), (0, m - a.shape[1])] + [(0, 0)] * (a.ndim - 2))  # noqa: E731
    return (np.concatenate([pad(s), pad(es)]), np.concatenate([pad(composed), pad(ecomposed)]),
            np.concatenate([n, en]))


#: Emission-absorption: the lines meeting the content the simulation wants at least (:func:`visible_lines`).
CONTENT_LINES = 96
#: Random points of the box tried for points of the content (:func:`content_lines`).
CONTENT_CANDIDATES = 1 << 17


def content_lines(scene, count: int):
    """``count`` lines in random directions through random points of the transfer function's content (of
    :data:`CONTENT_CANDIDATES` uniform points of the box, those where the field's extinction is non-zero),
    sampled as :func:`sampled_along`; None where no candidate is in the content."""
    field, tf = scene.field, scene.transfer_function
    rng = np.random.default_rng(tolerance.SEED + 1)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in field.bounds)
    points = lo + rng.random((CONTENT_CANDIDATES, 3)) * (hi - lo)
    values = reconstruct(field, scene.renderer).sample(points)
    content = points[np.asarray(tf.extinction(values)) > 0.0]
    if not len(content):
        return None
    centre = content[rng.integers(len(content), size=count)]
    direction = rng.normal(size=(count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return sampled_along(scene, centre - direction * diagonal(field) / 2.0, direction, PER_VOXEL)


def classified(s, live, tf) -> np.ndarray:
    """``(sigma, sigma r, sigma g, sigma b)`` of values ``s``, zero where not ``live``."""
    sigma = np.where(live, tf.extinction(s.ravel()).reshape(s.shape), 0.0)
    colour = tf.color(s.ravel()).reshape(*s.shape, 3)
    return np.concatenate([sigma[..., None], sigma[..., None] * colour], axis=-1)


def simulate_choice(scene) -> DefaultChoice:
    """The largest distance of :data:`LADDER` (and its classification) whose simulated error on the
    scene's random lines is at most ``MARGIN * TARGET``; the cheaper per unit length where two
    classifications qualify (pre-integration is tried only where it would sample less often)."""
    begin = time.perf_counter()
    if diagonal(scene.field) / scene.field.sample_spacing * PER_VOXEL > MAX_STEPS:  # a needle of a box
        return DefaultChoice("post", FINEST, scene.renderer.ert_threshold, float("nan"), time.perf_counter() - begin)
    mode = scene.renderer.compositing
    extremum = mode in ("mip", "minip")
    s, composed, n, step, lines = box_lines(scene, MIP_LINES if extremum else LINES, classify=not extremum)
    tf = scene.transfer_function
    if mode == "emission_absorption":
        s, composed, n = visible_lines(scene, s, composed, n)
        fine = composite(*segments(composed, n, 1), step)
        post = lambda k: rms(composite(*segments(composed, n, k), step), fine)  # noqa: E731
        pre = lambda k: rms(composite(*segments(linearised(s, n, tf, k), n, 1), step), fine)  # noqa: E731
    else:
        voxels, error, steps, brackets = extremum_choice(scene, s, n, lines, step)
        return DefaultChoice("post", voxels, scene.renderer.ert_threshold, float(error), time.perf_counter() - begin,
                             steps, brackets)
    target = target_of(mode)
    allow_pre = tolerance.narrowest_feature(tf) * (scene.renderer.preintegration_size - 1) \
        >= tolerance.PREINTEGRATION_NODES
    choice = emission_choice(post, pre if allow_pre else None, target)
    one_voxel = post(PER_VOXEL)  # the classic default's error: one sample a voxel, post-classified
    out_of_reach = choice[:2] == ("post", FINEST) and post(round(FINEST * PER_VOXEL)) > OUT_OF_REACH * MARGIN * target
    classic = None
    # met, but less accurately than one sample a voxel by more than the lines' rounding (a constant field's errors
    # are 1e-16 apart)
    looser = one_voxel + CLASSIC_SLACK * target < choice[2] <= MARGIN * target
    if out_of_reach or looser:  # (where the target is missed but in reach, the finest distance stays)
        classic = one_voxel
        choice = classic_choice(post, pre if allow_pre else None, one_voxel)
    ert = 1.0 - TARGET / 4.0 if mode == "emission_absorption" else scene.renderer.ert_threshold
    return DefaultChoice(choice[0], choice[1], ert, float(choice[2]), time.perf_counter() - begin,
                         refinement_steps(scene), refinement_brackets(scene), classic, out_of_reach)


def classic_choice(post, pre, one_voxel: float) -> tuple[str, float, float]:
    """Emission-absorption where the display target is out of reach or looser than the classic default: the
    cheapest choice no less accurate on the lines than one sample a voxel post-classified (``one_voxel``, the
    error ``post(PER_VOXEL)``): pre-integrated at up to :data:`PREINTEGRATED_GAIN` voxels where it meets that
    (:func:`emission_choice` at most one voxel apart), else one voxel itself (it meets its own error, with fewer
    samples than the ladder's 0.75)."""
    choice = emission_choice(post, pre, one_voxel, longest=1.0)
    return choice if choice[0] == "preintegrated" else ("post", 1.0, one_voxel)


def emission_choice(post, pre, target: float, longest: float | None = None) -> tuple[str, float, float]:
    """Emission-absorption: ``(classification, voxels, error)``, the largest distance of :data:`LADDER` whose
    simulated error ``post(k)`` meets ``target`` (:data:`FINEST` where none does), or pre-integrated (``pre(k)``;
    None: not allowed) where that meets it at :data:`PREINTEGRATED_GAIN` times the distance or more.
    ``longest`` (voxels): post-classified distances at most that, pre-integrated at most
    :data:`PREINTEGRATED_GAIN` times that."""
    cap = np.inf if longest is None else longest
    voxels, error = largest_meeting(post, [v for v in LADDER if v <= cap], target)
    choice = ("post", voxels, error) if voxels is not None else ("post", FINEST, error)
    if pre is not None:
        longer = [v for v in LADDER if PREINTEGRATED_GAIN * choice[1] <= v <= PREINTEGRATED_GAIN * cap]
        pv, pe = longest_meeting(pre, longer[::-1], target)
        if pv is not None:
            choice = ("preintegrated", pv, pe)
    return choice


def extremum_choice(scene, s: np.ndarray, n: np.ndarray, lines, step: float) -> tuple[float, float, int, int | None]:
    """MIP and MinIP: ``(voxels, error, steps, brackets)``, the distance (voxels), refinement steps and brackets
    of the cheapest :func:`ray_cost` among :func:`extremum_choices`, each at the largest distance of
    :data:`LADDER` whose simulated error on the lines (values ``s``, ``n`` fine steps of ``step`` each) meets
    :data:`MIP_TARGET` (:data:`FINEST` and the last error where none does); of the choices within
    :data:`COST_TIE` of the cheapest, the one with the most brackets, then the cheapest (the first on a tie)."""
    mode, tf = scene.renderer.compositing, scene.transfer_function
    sign = 1.0 if mode == "mip" else -1.0
    found = []
    for steps, brackets in extremum_choices(scene):
        fine = extremum_rgba(*refined_segments(s, n, 1, sign, steps, lines, step, brackets), sign, tf)
        post = lambda k: rms(extremum_rgba(*refined_segments(s, n, k, sign, steps, lines, step,  # noqa: E731
                                                             brackets), sign, tf), fine)
        voxels, error = largest_meeting(post, LADDER, target_of(mode))
        voxels = FINEST if voxels is None else voxels
        found.append((ray_cost(float(np.mean(n)) / PER_VOXEL, voxels, steps, brackets), voxels, error, steps, brackets))
    return level_choice(found)[1:]


def level_choice(found: list[tuple]):
    """Of ``found`` (``(cost, voxels, error, steps, brackets)`` each), those within :data:`COST_TIE` of the
    cheapest cost: the one with the most brackets, then the cheapest (the first on a tie)."""
    cheapest = min(f[0] for f in found)
    level = [f for f in found if f[0] <= (1.0 + COST_TIE) * cheapest]
    return min(level, key=lambda f: (-(f[4] or 0), f[0]))


def extremum_choices(scene) -> list[tuple[int, int | None]]:
    """MIP and MinIP: the ``(steps, brackets)`` pairs :func:`extremum_choice` simulates: the scene's own
    renderer.extremum_refinement or each of :data:`REFINEMENT_CHOICES`, with the scene's own
    renderer.extremum_brackets or each of :data:`BRACKET_CHOICES` (None where nothing is refined)."""
    r = scene.renderer
    steps = (refinement_steps(scene),) if r.extremum_refinement is not None else REFINEMENT_CHOICES
    brackets = (r.extremum_brackets,) if r.extremum_brackets is not None else BRACKET_CHOICES
    return [(k, b if k else None) for k in steps for b in (brackets if k else (None,))]


def ray_cost(length: float, voxels: float, steps: int, brackets: int | None) -> float:
    """A ray's modelled cost in samples of the loop: ``length`` voxels sampled every ``voxels``, and each
    refined bracket's ``steps`` + 2 fetches (its ends) at :data:`REFINE_FETCH_COST` samples each."""
    return length / voxels + (brackets or 0) * (steps + 2) * REFINE_FETCH_COST if steps else length / voxels


def largest_meeting(error_at, ladder, target: float = TARGET) -> tuple[float | None, float]:
    """The first distance of ``ladder`` (voxels, largest first) whose simulated RMS error
    ``error_at(k)`` (``k`` fine steps a segment) is at most ``MARGIN * target``, and that error (None,
    the last error, where none does)."""
    error = np.inf
    for voxels in ladder:
        error = error_at(int(round(voxels * PER_VOXEL)))
        if error <= MARGIN * target:
            return voxels, error
    return None, error


def longest_meeting(error_at, ladder, target: float = TARGET) -> tuple[float | None, float]:
    """From the shortest distance of ``ladder`` (smallest first) up: the last whose simulated error is
    at most ``MARGIN * target`` before one that is not (None where the first is not)."""
    found, found_error = None, np.inf
    for voxels in ladder:
        error = error_at(int(round(voxels * PER_VOXEL)))
        if error > MARGIN * target:
            break
        found, found_error = voxels, error
    return found, found_error


def segments(values: np.ndarray, n: np.ndarray, k: int):
    """The ray caster's segments of each line (``k`` fine steps long from the entry, the last
    shortened to the ``n`` steps in the box), each sampled at its middle (a fine step's middle: ``k``
    odd, and the last segment's nearest): ``(samples (lines, m, ...), lengths (lines, m) in fine steps,
    0 past the end)``."""
    m = (int(n.max(initial=0)) + k - 1) // k
    first = k * np.arange(m)[None, :]
    length = np.clip(n[:, None] - first, 0, k)
    if k == 1:  # every fine step is a segment (the lines' reference)
        return values[:, :m], length
    idx = np.minimum(first + (np.maximum(length, 1) - 1) // 2, max(values.shape[1] - 1, 0))
    take = idx[..., None] if values.ndim == 3 else idx
    return np.take_along_axis(values, take, axis=1), length


def refined_segments(s, n, k: int, sign: float, steps: int, lines: Lines, step: float, brackets: int | None = 1):
    """:func:`segments` of each line at ``k`` fine steps a segment, with the extreme segment's sample
    replaced by its extremum refined as the ray caster refines it (:func:`refine_extremum`: ``steps``
    parabolic steps, the bracket one segment each side within the box), and with ``brackets`` 2 the
    second candidate's (the first peak, a sample at least the samples beside it, holding the best value two or
    more segments from the extreme one, :class:`~dvr_gl.reference.discrete.SecondCandidates`) too:
    ``(samples, lengths)``."""
    samples, length = segments(s, n, k)
    if not steps:
        return samples, length
    signed = np.where(length > 0, sign * samples, -np.inf)
    j = np.argmax(signed, axis=1)  # the first holding the extremum
    rows = np.nonzero(length[:, 0] > 0)[0]
    samples = samples.copy()
    samples[rows, j[rows]] = sign * refined_at(signed, length, rows, j[rows], k, sign, steps, lines, step, n)
    if brackets == 2:  # the best peak (at least the samples beside it) two or more segments from the extreme one
        none = np.full((len(signed), 1), -np.inf)
        peak = (signed >= np.concatenate([none, signed[:, :-1]], axis=1)) & \
            (signed >= np.concatenate([signed[:, 1:], none], axis=1))
        near = np.abs(np.arange(signed.shape[1])[None, :] - j[:, None]) <= 1
        others = np.where(near | ~peak, -np.inf, signed)
        j2 = np.argmax(others, axis=1)
        rows = rows[others[rows, j2[rows]] > -np.inf]
        samples[rows, j2[rows]] = sign * refined_at(signed, length, rows, j2[rows], k, sign, steps, lines, step, n)
    return samples, length


def refined_at(signed, length, rows, j, k: int, sign: float, steps: int, lines: Lines, step: float, n):
    """The (signed) extremum refined around segment ``j`` of lines ``rows`` (:func:`refined_segments`)."""
    fine = k * j + (np.maximum(length[rows, j], 1) - 1) // 2   # the fine step it samples (segments())
    t0 = lines.t0[rows]
    at = t0 + (fine + 0.5) * step
    part = Lines(lines.start[rows], lines.direction[rows], t0, lines.reconstruction)
    return refine_extremum(lambda t: sign * part.value_at(t), at, signed[rows, j], t0, t0 + n[rows] * step,
                           k * step, steps)


def composite(composed: np.ndarray, length: np.ndarray, step: float) -> np.ndarray:
    """Front-to-back emission-absorption of each line's segments: samples ``(sigma, sigma r, sigma g,
    sigma b)``, lengths ``length`` in fine steps of ``step`` world units; premultiplied RGBA ``(lines, 4)``."""
    sigma = composed[..., 0]
    depth = sigma * length * step
    opacity = -np.expm1(-depth)
    before = np.exp(-(np.cumsum(depth, axis=1) - depth))  # transmittance to each segment
    colour = np.divide(composed[..., 1:], sigma[..., None], out=np.zeros_like(composed[..., 1:]),
                       where=sigma[..., None] > 0)
    weight = before * opacity
    return np.concatenate([(weight[..., None] * colour).sum(axis=1), weight.sum(axis=1, keepdims=True)], axis=1)


def linearised(s, n, tf, k: int) -> np.ndarray:
    """Each line's data replaced, within each segment ``k`` fine steps long, by the line between the
    values at the segment's ends (what pre-integration integrates exactly), classified at the fine
    steps: ``(sigma, sigma r, sigma g, sigma b)``, zero past ``n``."""
    m = s.shape[1]
    edge = np.concatenate([s[:, :1], (s[:, 1:] + s[:, :-1]) / 2.0, s[:, -1:]], axis=1)  # at the steps' ends
    last = np.maximum(n[:, None], 1)
    i = np.arange(m)[None, :]
    lo = (i // k) * k
    hi = np.minimum(lo + k, last)
    e0 = np.take_along_axis(edge, np.minimum(lo, m), 1)
    e1 = np.take_along_axis(edge, np.minimum(hi, m), 1)
    lin = e0 + (e1 - e0) * (i + 0.5 - lo) / np.maximum(hi - lo, 1)
    return classified(lin, i < n[:, None], tf)


def extremum_rgba(s, length, sign: float, tf) -> np.ndarray:
    """The maximum (``sign`` 1) or minimum (-1) of each line's segment samples, classified once:
    premultiplied RGBA ``(lines, 4)`` with the opacity of one unit distance; transparent without one."""
    value = sign * np.max(np.where(length > 0, sign * s, -np.inf), axis=1)
    has = np.isfinite(value)
    out = np.zeros((len(s), 4))
    colour = tf.color(value[has])
    alpha = -np.expm1(-tf.extinction(value[has]) * tf.unit_distance)
    out[has] = np.concatenate([colour * alpha[:, None], alpha[:, None]], axis=1)
    return out


def rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def resolve_defaults(scene):
    """``scene`` with the ray caster's defaults chosen by the scene (:func:`choose_defaults`) where it
    gave no sample distance, no tolerance and no early-termination threshold or classification of its
    own; unchanged where it did, or where the simulation does not model it."""
    requested = scene.spec.renderer if scene.spec is not None else None
    if requested is None or not modelled(scene):
        return scene
    if any(getattr(requested, k, None) is not None for k in PLUGIN.resolve_unless):
        return scene
    choice = choose_defaults(scene)
    changes = choice.renderer_changes(scene.field.sample_spacing)
    defaults = type(requested)()
    for key in ("classification", "ert_threshold"):  # a value the user gave wins
        if getattr(requested, key) != getattr(defaults, key):
            changes.pop(key)
    return dataclasses.replace(scene, renderer=dataclasses.replace(scene.renderer, **changes))


def resolve(scene):
    """The ray caster's resolution hook (its plugin's ``resolve``): ``renderer.tolerance`` replaced by the
    settings the error model chooses for it and the a-posteriori check confirms (:func:`.tolerance.check`, which
    renders the scene small on the ray caster), so that the effective scene holds those settings and
    rendering it again repeats the image.  Without a tolerance or a sample distance, the defaults are
    chosen by the scene (:func:`resolve_defaults`)."""
    requested = scene.spec.renderer if scene.spec is not None else scene.renderer
    wanted = getattr(requested, "tolerance", None)
    if wanted is None:
        return resolve_defaults(scene)
    if requested.sample_distance is not None or requested.sample_distance_voxels is not None:
        raise SceneError("renderer: give tolerance or a sample distance, not both (the tolerance chooses it)")
    # the settings the tolerance chooses from: the plain ones (Scene.with_renderer would choose the defaults)
    plain = dataclasses.replace(requested, tolerance=None)
    base = dataclasses.replace(scene, renderer=dataclasses.replace(scene.renderer, tolerance=None),
                               spec=dataclasses.replace(scene.spec, renderer=plain) if scene.spec else None)
    chosen, choice = tolerance.apply(base, wanted)
    return chosen.replace(tolerance_choice=choice)
