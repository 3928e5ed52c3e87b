"""One field of several, classified by its role (:mod:`dvr_gl.fields.layers`): what the references' mixture
(:mod:`.fields`) asks of each member, in float64, at world points inside the member's box.

* ``scalar``: the single-field :class:`~dvr_gl.reference.model.OpticalModel` of the member's own scene.
* ``rgb`` (:mod:`dvr_gl.fields.color`): the same model with the four components ``(r, g, b, x)`` reconstructed
  alike: colour ``(r, g, b)`` from the data, extinction from the member's transfer function of ``x`` (tabulated as
  a scalar's, or exact), gradient opacity and shading from the gradient of ``x``.  Pre-classification classifies
  the voxels to ``(sigma r, sigma g, sigma b, sigma)`` (associated) and filters those.  Pre-integration: ``tau``
  from the member's table of ``x`` (exact for ``x`` linear along the segment), the colour the data's at the
  segment's sample (exact for constant colour): ``C = rgb (1 - exp(-tau))``.  Its isosurface is a level of ``x``
  (the member's iso-value), coloured by the data's colour there, shaded by the gradient of ``x``.
* ``label`` (:mod:`dvr_gl.labels`): the label ``L*`` of the indicator rule (or the nearest voxel's), its colour
  and extinction from the member's :class:`~dvr_gl.labels.LabelTable` (exact: a table has no interpolation);
  shaded with the normal ``-grad I_L* / |grad I_L*|`` (zero below 1e-5 per voxel); no gradient opacity (the
  indicator is not a value).  Categorical, it has no pre-integration table: a segment takes its sample's
  label, ``C = c (1 - exp(-sigma len))``, ``tau = sigma len`` (as post-classification).

An *oriented* member (its direction matrix differs from the first member's, :mod:`dvr_gl.fields.layers`) is
classified in the shared frame through :class:`OrientedField`: every point is mapped into the member's own frame
(``q = A p + b``) to be sampled there, directions by ``A``, gradients back by ``A^T``; the lights, the camera
and the depth cue stay in the shared frame.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import SceneError
from ..fields import filter_parameters
from ..labels import label_sample
from ..preintegration import shortened
from ..shading import blinn_phong, normals_from_gradient
from .classification import PreClassifier
from .model import OpticalModel, depth_cue


def member_scene(scene, layer, transform=None):
    """The single-field scene of one member: its grid (seen from the shared frame through ``transform``, the
    member's ``(A, b)`` of :func:`dvr_gl.fields.layers.member_transform`, where it has one), transfer function
    and iso-value, the scene's camera, image and every other setting."""
    renderer = scene.renderer
    if hasattr(renderer, "iso_value") and layer.iso_value is not None:
        renderer = dataclasses.replace(renderer, iso_value=float(layer.iso_value))
    field = layer.field if transform is None else OrientedField(layer.field, *transform)
    return dataclasses.replace(scene, field=field, transfer_function=layer.transfer_function,
                               transfer_functions=(), sources=(), renderer=renderer)


class InSharedFrame:
    """A member's reconstruction (:class:`~dvr_gl.fields.reconstruction.SampledField`) read at shared-frame
    points: sampled at ``q = A p + b``, its gradient (a row per point) turned back by ``g A`` (``A^T g``), its
    knots found on the mapped rays (the map is rigid: ray parameters are kept)."""

    def __init__(self, inner, a, b):
        self.inner, self.a, self.b = inner, a, b

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def mapped(self, points):
        return np.asarray(points, dtype=np.float64) @ self.a.T + self.b

    def sample(self, points):
        return self.inner.sample(self.mapped(points))

    def gradient(self, points):
        return self.inner.gradient(self.mapped(points)) @ self.a

    def knots(self, origins, directions, t0, t1):
        return self.inner.knots(self.mapped(origins), np.asarray(directions, np.float64) @ self.a.T, t0, t1)

    def taps(self, points):
        return self.inner.taps(self.mapped(points))


class OrientedField:
    """An oriented member's grid as the references see it from the shared frame (module doc): what the models
    ask of a field, with :meth:`reconstruct` and :meth:`reconstruct_values` read through
    :class:`InSharedFrame`; ``bounds`` the shared-frame bounding box of its box (for the depth cue's range)."""

    def __init__(self, volume, a, b):
        self.volume, self.a, self.b = volume, np.asarray(a, np.float64), np.asarray(b, np.float64)

    def __getattr__(self, name):
        return getattr(self.volume, name)

    def to_member(self, points):
        return np.asarray(points, dtype=np.float64) @ self.a.T + self.b

    @property
    def bounds(self):
        lo, hi = self.volume.box
        corners = np.array([[(lo, hi)[(c >> k) & 1][k] for k in range(3)] for c in range(8)], dtype=np.float64)
        shared = (corners - self.b) @ self.a
        return shared.min(axis=0), shared.max(axis=0)

    box = bounds

    def reconstruct(self, *args, **kwargs):
        return InSharedFrame(self.volume.reconstruct(*args, **kwargs), self.a, self.b)

    def reconstruct_values(self, *args, **kwargs):
        return InSharedFrame(self.volume.reconstruct_values(*args, **kwargs), self.a, self.b)


def optics(scene, layer, exact: bool, segment_length: float | None):
    """The model of member ``layer`` (its role's, see the module doc) in its own scene ``scene``."""
    if layer.role == "label":
        return LabelOptics(scene, layer.transfer_function)
    model = OpticalModel(scene, exact=exact, segment_length=segment_length)
    if layer.role == "rgb":
        colour_model(model, scene)
    return model


class Component:
    """The fourth component ``x`` of a colour reconstruction: what an rgb member's transfer function reads (the
    scalar of its model: values, gradients, knots, the degree between them)."""

    def __init__(self, reconstruction):
        self.reconstruction = reconstruction
        self.degree = reconstruction.degree
        self.knots = reconstruction.knots
        self.gradient = reconstruction.gradient  # of x alone (ColorReconstruction)

    def sample(self, points: np.ndarray) -> np.ndarray:
        return self.reconstruction.sample(points)[:, 3]


class ColourClassifier:
    """Post-classification of a colour volume: colour the reconstructed ``(r, g, b)``, extinction the table's at
    the reconstructed ``x``."""

    def __init__(self, reconstruction, table):
        self.reconstruction = reconstruction
        self.lookup = table.lookup if hasattr(table, "lookup") else table.evaluate

    def __call__(self, points: np.ndarray, scalars=None):
        rgbx = self.reconstruction.sample(points)
        return np.clip(rgbx[:, :3], 0.0, None), self.lookup(rgbx[:, 3])[1]


def colour_model(model: OpticalModel, scene) -> None:
    """Turn a single-field model of a colour volume into the rgb role's (module doc): its scalar is ``x``, its
    classification takes the colour from the data."""
    r = scene.renderer
    reconstruction = model.scalar
    model.scalar = Component(reconstruction)
    if isinstance(model.classify, PreClassifier):
        sigma = model.tf.evaluate(np.asarray(scene.field.data[..., 3], np.float64))[1]
        rgb = np.asarray(scene.field.data[..., :3], np.float64)
        first = rgb * sigma[..., None] if r.associated_colors else rgb
        model.classify.field = scene.field.reconstruct_values(np.concatenate([first, sigma[..., None]], axis=-1),
                                                              r.filter, **filter_parameters(r))
    else:
        model.classify = ColourClassifier(reconstruction, model.table)
    if model.preintegration is not None:
        model.preintegrated = lambda *a: _colour_segments(model, reconstruction, *a)
    model.hit_colour = lambda points, directions: _surface_colour(model, reconstruction, points, directions)


def _surface_colour(model, reconstruction, points, directions) -> np.ndarray:
    """An rgb member's isosurface colour at points on it: the data's, shaded by the gradient of ``x``."""
    colour = np.clip(reconstruction.sample(points)[:, :3], 0.0, None)
    return colour if model.shading is None else model.shade(colour, points, directions)


def _colour_segments(model, reconstruction, front, back, middle, directions, fraction):
    """An rgb member's segments: ``tau`` from its table of ``x``, the data's colour at ``middle`` (module doc);
    gradient opacity and shading as a scalar's."""
    _, tau = model.preintegration.lookup(model.scalar.sample(front), model.scalar.sample(back))
    _, tau = shortened(np.zeros((len(tau), 3)), tau, fraction)
    colour = np.clip(reconstruction.sample(middle)[:, :3], 0.0, None)
    if model.shading is not None or model.gradient_reference is not None:
        gradient = model.scalar.gradient(middle)
        if model.gradient_reference is not None:
            tau = tau * np.minimum(1.0, np.linalg.norm(gradient, axis=1) / model.gradient_reference)
        if model.shading is not None:
            colour = blinn_phong(colour, normals_from_gradient(gradient, model.epsilon), directions, model.shading)
    return colour * (-np.expm1(-tau))[:, None], tau


class LabelOptics:
    """A label member's classification (module doc), with the attributes of an :class:`OpticalModel` the
    mixture reads."""

    def __init__(self, scene, table):
        r = scene.renderer
        self.field, self.table = scene.field, table
        self.filter = "nearest" if r.filter == "nearest" else "linear"
        self.scalar = scene.field.reconstruct(self.filter)  # its knots: the cells the label rule works in
        xray = r.compositing == "xray"
        self.shading = r.shading if r.shading.enabled and not xray else None
        self.epsilon = 1e-5 / scene.field.sample_spacing  # the indicator's scale is 1 (per voxel: 1 / spacing)
        cue = getattr(r, "depth_cue", 1.0)
        self.depth_cue = depth_cue(scene) if r.compositing in ("average", "xray") and cue < 1.0 else None
        self.preintegration = None
        self.gradient_reference = None

    def labels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(labels (N,), indicator gradient (N, 3))`` at world points (an oriented member's: mapped into its
        frame, the gradient turned back)."""
        if isinstance(self.field, OrientedField):
            labels, gradient = label_sample(self.field.volume, self.field.to_member(points), self.filter)
            return labels, gradient @ self.field.a
        return label_sample(self.field, points, self.filter)

    def visible(self, points: np.ndarray) -> np.ndarray:
        """1 where the label at a point is visible (an isosurface of labels is hit there), else 0."""
        return self.table.visible(self.labels(points)[0]).astype(np.float64)

    def emission(self, points: np.ndarray, directions: np.ndarray, cells=None):
        labels, gradient = self.labels(points)
        colour, sigma = self.table.lookup(labels)
        if self.shading is not None:
            colour = blinn_phong(colour, normals_from_gradient(gradient, self.epsilon), directions, self.shading)
        return colour, sigma

    def xray_emission(self, points: np.ndarray, directions: np.ndarray, cells=None):
        colour, sigma = self.table.lookup(self.labels(points)[0])
        emitted = colour * sigma[:, None]
        if self.depth_cue is not None:
            emitted = emitted * self.depth_cue(points)[:, None]
        return emitted, sigma

    def preintegrated(self, front, back, middle, directions, fraction):
        colour, sigma = self.emission(middle, directions)
        tau = sigma * np.linalg.norm(back - front, axis=1)
        return colour * (-np.expm1(-tau))[:, None], tau

    def hit_colour(self, points: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """The colour of the label surface at points on its visible side: the table's, shaded."""
        return self.emission(points, directions)[0]

    def breakpoints(self) -> np.ndarray:
        return np.zeros(0)

    def classify_value(self, values):
        raise SceneError("a label map has no value to project: use emission_absorption or isosurface")
