"""Render to a tolerance: the cheapest settings expected to meet an RMS image error ``E``.

The model (after Bergner et al. 2006, "A spectral analysis of function composition
and its implications for sampling in direct volume visualization"): what a ray
integrates is the transfer function *composed* with the reconstructed data,
``sigma(s(x))`` and ``sigma c(s(x))``, whose bandwidth is roughly the transfer
function's bandwidth (cycles per value unit) times the data's gradient, plus the
data's own (Carson's rule for frequency modulation).  Rather than multiply
percentiles, the composed signal is sampled along random lines through the
volume (``LINES`` lines, ``OVERSAMPLING`` samples per voxel, the scene's filter
and its exact transfer function) and its power spectrum measured directly; the
bandwidth ``nu`` is the frequency below which ``ENERGY`` of the signal's variance
lies, and the Nyquist distance is ``1 / (2 nu)``.

For post-classification the signal is the composed one; pre-integrated
classification integrates the transfer function exactly between two samples when
the data is linear between them, so its signal is the data itself, on the parts
of the lines where the transfer function is not transparent.

The error then follows a power law in the sample distance relative to the
Nyquist distance, scaled by the signal's amplitude ``A`` (the standard deviation
over the lines inside the box of the opacity of one voxel's length,
``1 - exp(-sigma * voxel)``: it saturates where an optical depth would not, as
the image does): ``E(d) = kappa * A * (d / d_nyquist) ** p``, with ``kappa`` and ``p``
fitted to measured errors (``dvr bench tradeoff`` against the converged reference,
on the calibration scenes listed in :data:`CALIBRATION`) and ``kappa`` raised to
the upper envelope of those measurements, so the prediction errs on the safe
side.  docs/tolerance.md states how well it predicts on the shared datasets.

Early ray termination is set so that what it drops is below ``E / 4``.

The model is only a first guess: a transfer-function feature much narrower than the data range
(a tent over 0.5 % of it, a thin shell) makes the composed signal spiky, and its amplitude and
bandwidth along a few random lines are then poorly estimated.  So the choice is checked a
posteriori (:func:`check`): the GPU ray caster renders the scene (at most ``CHECK_PIXELS`` pixels,
the same camera) at ``d``, ``d/2`` and ``d/4``; with ``r1``, ``r2`` the RMS differences of
consecutive images, the convergence order is ``p = log2(r1 / r2)`` (kept in [1, 3]) and the
error of the image at ``d`` by Richardson extrapolation ``r1 / (1 - 2^-p)`` (the geometric sum
of the differences still to come).  While that exceeds ``MARGIN E``, ``d`` is halved.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ... import progress
from ...errors import SceneError
from ...fields import diagonal, reconstruct

LINES = 192
OVERSAMPLING = 8          # samples per voxel along the lines
ENERGY = 0.999             # fraction of the signal's variance below the bandwidth
SEED = 20261121
MIN_TOLERANCE, MAX_TOLERANCE = 5e-4, 0.1
MARGIN = 0.75             # of E, for the sampling error (early termination takes up to E / 4)
CHECK_PIXELS = 64 * 64     # the a-posteriori check renders at most this many pixels
CHECK_HALVINGS = 6         # at most 64x finer than the model's guess
# Pre-integration is considered only where every interval of the transfer function on which it is
# not transparent spans this many table nodes: narrower, the table's own error (bilinear between
# nodes) no longer falls with the step (measured 1.3e-3 for a 2 % tent, 9e-3 for 0.5 %, 256 nodes).
PREINTEGRATION_NODES = 8
# The a-posteriori check switches hardware to shader filtering where they differ by more than this
# fraction of E (8-bit weights on a narrow tent: measured 5e-3 RMS on 8-bit data, a 2 % tent).
FILTERING_SHARE = 0.25
# Cost of a sample relative to post-classification, measured (dvr bench tradeoff, raycast, 64^3 demo):
PREINTEGRATED_COST = 1.15


@dataclass(frozen=True)
class ErrorLaw:
    """``E = kappa * amplitude * (d / d_nyquist) ** power`` (RMS over the image, colour and alpha)."""

    kappa: float
    power: float

    def error(self, ratio: float, amplitude: float) -> float:
        return self.kappa * amplitude * ratio ** self.power

    def ratio_for(self, tolerance: float, amplitude: float) -> float:
        if amplitude <= 0:
            return np.inf
        return (tolerance / (self.kappa * amplitude)) ** (1.0 / self.power)


# Fitted by benchmarks/tolerance_calibration.py (see docs/tolerance.md).
LAWS = {"post": ErrorLaw(kappa=0.101, power=2.07), "preintegrated": ErrorLaw(kappa=0.0545, power=1.29)}


def random_lines(field, count: int, seed: int = SEED):
    """``count`` lines through the field's box: random directions, through uniformly random points,
    each as (start, unit direction, length) spanning the box's diagonal around its point."""
    rng = np.random.default_rng(seed)
    lo, hi = field.bounds
    centre = lo + rng.random((count, 3)) * (hi - lo)
    direction = rng.normal(size=(count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    length = diagonal(field)
    return centre - direction * length / 2.0, direction, length


def line_samples(scene, count: int = LINES, oversampling: int = OVERSAMPLING):
    """The data and the composed signal along random lines: ``(s, signal, inside, step)`` with
    ``s`` (lines, n), ``signal`` (lines, n, 4) = (sigma, sigma r, sigma g, sigma b) in per world
    unit (zero outside the box), ``inside`` the samples in the box, ``step`` in world units."""
    field, tf = scene.field, scene.transfer_function
    start, direction, length = random_lines(field, count)
    step = field.sample_spacing / oversampling
    t = np.arange(int(length / step)) * step
    points = start[:, None, :] + direction[:, None, :] * t[None, :, None]
    lo, hi = field.bounds
    inside = np.all((points >= lo) & (points <= hi), axis=-1)
    s = reconstruct(field, scene.renderer).sample(points.reshape(-1, 3)).reshape(inside.shape)
    sigma = np.where(inside, tf.extinction(s.ravel()).reshape(s.shape), 0.0)
    colour = tf.color(s.ravel()).reshape(*s.shape, 3)
    return s, np.concatenate([sigma[..., None], sigma[..., None] * colour], axis=-1), inside, step


def bandwidth(signal: np.ndarray, step: float, energy: float = ENERGY) -> float:
    """Cycles per world unit below which ``energy`` of the variance of ``signal`` (lines along
    axis 1; any trailing channels) lies; 0 for a constant signal."""
    x = signal - signal.mean(axis=1, keepdims=True)
    power = np.abs(np.fft.rfft(x, axis=1)) ** 2
    power = power.reshape(power.shape[0], power.shape[1], -1).sum(axis=(0, 2))
    power[0] = 0.0
    total = power.sum()
    if not total > 0:
        return 0.0
    frequencies = np.fft.rfftfreq(signal.shape[1], step)
    k = int(np.searchsorted(np.cumsum(power) / total, energy))
    return float(frequencies[min(k, len(frequencies) - 1)])


@dataclass(frozen=True)
class SamplingModel:
    """Nyquist distances (world units) of the signals each classification integrates."""

    post: float            # composed transfer function and data
    preintegrated: float   # the data where the transfer function is not transparent
    amplitude: float       # standard deviation of the opacity of one voxel's length in the box

    def distance_for(self, classification: str, tolerance: float) -> float:
        return getattr(self, classification) * LAWS[classification].ratio_for(tolerance, self.amplitude)

    def predicted_error(self, classification: str, distance: float) -> float:
        return LAWS[classification].error(distance / getattr(self, classification), self.amplitude)


def sampling_model(scene) -> SamplingModel:
    """Measure the bandwidths of the scene's signals (a fraction of a second for 64^3)."""
    s, composed, inside, step = line_samples(scene)
    voxel = scene.field.sample_spacing
    visible = composed[..., 0] > 0
    nu_post = bandwidth(composed, step)
    # Pre-integration: the data, on the visible parts (constant elsewhere, so it adds nothing)
    near = _dilate(visible, 2 * OVERSAMPLING)
    if near.any():
        held = np.where(near, s, s[near].mean())
        nu_pre = bandwidth(held, step)
    else:
        nu_pre = 0.0
    amplitude = float(np.std(-np.expm1(-composed[..., 0][inside] * voxel)))
    return SamplingModel(post=_nyquist(nu_post, voxel), preintegrated=_nyquist(nu_pre, voxel), amplitude=amplitude)


def _nyquist(nu: float, voxel: float) -> float:
    """``1 / (2 nu)``, kept within [1/64, 64] voxels (a constant signal has no Nyquist rate)."""
    return float(np.clip(1.0 / (2.0 * nu), voxel / 64.0, 64.0 * voxel)) if nu > 0 else 64.0 * voxel


def _dilate(mask: np.ndarray, reach: int) -> np.ndarray:
    """``mask`` grown by ``reach`` samples along each line (axis 1)."""
    c = np.cumsum(np.pad(mask.astype(np.int32), ((0, 0), (reach + 1, reach))), axis=1)
    return (c[:, 2 * reach + 1:] - c[:, :-(2 * reach + 1)]) > 0


@dataclass(frozen=True)
class Choice:
    """What :func:`choose` picked and why."""

    classification: str
    sample_distance: float      # world units
    ert_threshold: float
    filtering: str
    predicted_error: float
    model: SamplingModel
    estimated_error: float | None = None   # the a-posteriori check's (Richardson) estimate
    first_guess: float | None = None       # the model's sample distance, before the check

    def renderer_changes(self) -> dict:
        return {"classification": self.classification, "sample_distance": self.sample_distance,
                "ert_threshold": self.ert_threshold, "filtering": self.filtering}

    def describe(self, voxel: float) -> str:
        text = (f"{self.classification} classification, sample distance {self.sample_distance / voxel:.3g} voxel, "
                f"early termination at {self.ert_threshold:g}, {self.filtering} filtering; "
                f"predicted RMS error {self.predicted_error:.2g}")
        if self.estimated_error is not None:
            text += f", estimated {self.estimated_error:.2g} by rendering at d, d/2 and d/4"
            if self.first_guess is not None and self.first_guess != self.sample_distance:
                text += f" (the model's {self.first_guess / voxel:.3g} voxel was refined)"
        return text


def check_tolerance(scene, tolerance: float):
    r = scene.renderer
    if not MIN_TOLERANCE <= tolerance <= MAX_TOLERANCE:
        raise SceneError(f"tolerance {tolerance:g} is outside the range the error model is fitted for "
                         f"({MIN_TOLERANCE:g} to {MAX_TOLERANCE:g} RMS); choose a value in it")
    if r.name != "raycast":
        raise SceneError(f"a tolerance chooses settings of the ray caster; renderer {r.name!r} is not modelled "
                         f"(use renderer raycast, or set the sample distance yourself)")
    if r.compositing != "emission_absorption":
        raise SceneError(f"a tolerance is modelled for emission_absorption compositing, not {r.compositing}; "
                         f"set the sample distance yourself")
    if r.shading.enabled or r.gradient_opacity or r.jitter or r.scattering.enabled:
        raise SceneError("a tolerance is modelled without shading, scattering, gradient opacity or jitter; turn "
                         "them off or set the sample distance yourself")


def choose(scene, tolerance: float, model: SamplingModel | None = None) -> Choice:
    """The classification and sample distance of least expected cost whose predicted RMS error
    is at most ``tolerance``, and early termination dropping at most ``tolerance / 4``
    (``model``: the scene's :func:`sampling_model`, if already measured)."""
    check_tolerance(scene, tolerance)
    model = model or sampling_model(scene)
    voxel = scene.field.sample_spacing
    ert = 1.0 - tolerance / 4.0  # what termination drops is at most 1 - threshold
    options = []
    classifications = (("post", 1.0), ("preintegrated", PREINTEGRATED_COST))
    if narrowest_feature(scene.transfer_function) * (scene.renderer.preintegration_size - 1) < PREINTEGRATION_NODES:
        classifications = classifications[:1]
    for classification, cost in classifications:
        d = min(model.distance_for(classification, 0.75 * tolerance), 8.0 * voxel)
        d = max(d, voxel / 64.0)
        options.append((cost / d, classification, d))
    _, classification, d = min(options)
    # The scene's filtering: every texture is filtered in float on llvmpipe (uint8 as R16F: .grid.textures), and
    # where a texture unit rounds (8-bit weights or results), check() measures it and switches to the shader's.
    return Choice(classification, d, ert, scene.renderer.filtering, model.predicted_error(classification, d), model)


def narrowest_feature(tf) -> float:
    """The narrowest interval between control points on which the transfer function is not
    transparent, as a fraction of its domain (1 if there is none)."""
    points = np.asarray(tf.points)
    lo, hi = tf.domain
    if len(points) < 2 or hi <= lo:
        return 1.0
    visible = (points[:-1, 4] > 0) | (points[1:, 4] > 0)
    widths = np.diff(points[:, 0])[visible]
    return float(widths.min() / (hi - lo)) if len(widths) else 1.0


def check_scene(scene):
    """``scene`` at most :data:`CHECK_PIXELS` pixels large, the same camera (the RMS over a coarser
    pixel grid of the same image estimates the same RMS)."""
    w, h = scene.image.width, scene.image.height
    shrink = min(1.0, float(np.sqrt(CHECK_PIXELS / (w * h))))
    if shrink >= 1.0:
        return scene
    return scene.replace(image=dataclasses.replace(scene.image, width=max(1, round(w * shrink)),
                                                   height=max(1, round(h * shrink))))


def richardson(coarse: np.ndarray, middle: np.ndarray, fine: np.ndarray) -> tuple[float, float]:
    """The error of ``coarse`` (RMS over the image, RGBA) from renders at ``d``, ``d/2``, ``d/4``:
    ``(r1 / (1 - 2^-p), p)`` with ``r1``, ``r2`` the RMS differences and ``p = log2(r1 / r2)`` in [1, 3]."""
    r1, r2 = _rms(coarse, middle), _rms(middle, fine)
    p = float(np.clip(np.log2(r1 / r2), 1.0, 3.0)) if r1 > 0 and r2 > 0 else 1.0
    return r1 / (1.0 - 2.0 ** -p), p


def check(scene, choice: Choice, tolerance: float, renderer=None) -> Choice:
    """The choice with its sample distance halved until the Richardson estimate of its error (see the
    module doc) is at most ``MARGIN tolerance``, and that estimate recorded; hardware filtering
    becomes shader filtering where the two differ by more than ``FILTERING_SHARE tolerance``."""
    from .. import create_renderer

    own = renderer is None
    renderer = renderer or create_renderer("raycast")
    try:
        small = check_scene(scene.with_renderer(**choice.renderer_changes()))
        # the renders: 2 to compare the filterings, 3 to start, at most CHECK_HALVINGS more
        renders = (2 if choice.filtering == "hardware" else 0) + 3 + CHECK_HALVINGS
        with progress.task(f"tolerance {tolerance:g}: checking the sample distance", renders, "render") as step:
            render = _counting(renderer, step)
            if choice.filtering == "hardware":  # a unit's rounding (8-bit weights) is a bias no step removes
                shader = small.with_renderer(filtering="shader")
                if _rms(render(small), render(shader)) > FILTERING_SHARE * tolerance:
                    choice, small = dataclasses.replace(choice, filtering="shader"), shader
            d, estimate = _refine(render, small, tolerance)
            step(render.done, render.done)  # finished early: the halvings were not all needed
    finally:
        if own:
            renderer.close()
    if estimate > tolerance:  # never deliver an image that is estimated to break the promise
        voxel = scene.field.sample_spacing
        raise SceneError(f"renderer.tolerance {tolerance:g} cannot be met: the error is still estimated at "
                         f"{estimate:.2g} at a sample distance of {d / voxel:.3g} voxel, {2 ** CHECK_HALVINGS}x "
                         f"finer than the model's choice; ask for a larger tolerance or set the sample "
                         f"distance yourself")
    return dataclasses.replace(choice, sample_distance=d, estimated_error=estimate,
                               first_guess=choice.sample_distance,
                               predicted_error=choice.model.predicted_error(choice.classification, d))


def _counting(renderer, step):
    """``renderer.render`` that tells ``step`` how many renders were done (``render.done``)."""
    def render(scene):
        image = renderer.render(scene)
        render.done += 1
        step(render.done)
        return image
    render.done = 0
    return render


def _refine(render, small, tolerance: float) -> tuple[float, float]:
    """(sample distance, its estimated error): from ``small``'s, halved while the estimate exceeds
    ``MARGIN tolerance`` (at most ``CHECK_HALVINGS`` times); ``render(scene)`` renders."""
    d = small.renderer.sample_distance
    images = [render(small.with_renderer(sample_distance=d / k)) for k in (1, 2, 4)]
    for halving in range(CHECK_HALVINGS + 1):
        estimate, _ = richardson(*images)
        if estimate <= MARGIN * tolerance or halving == CHECK_HALVINGS:
            break
        d /= 2.0
        images = images[1:] + [render(small.with_renderer(sample_distance=d / 4))]
    return d, estimate


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(np.float64) - b) ** 2)))


def apply(scene, tolerance: float, model: SamplingModel | None = None, verify: bool = True, renderer=None):
    """``scene`` with the chosen settings, and the :class:`Choice` (``verify``: checked a posteriori
    by rendering, :func:`check`, with ``renderer``: a ray caster to borrow, or None for one of its own)."""
    choice = choose(scene, tolerance, model)
    if verify:
        choice = check(scene, choice, tolerance, renderer)
    return scene.with_renderer(**choice.renderer_changes()), choice
