"""Fields: what renderers and references sample.

Every kind of data (the regular grid, the tetrahedral mesh, SPH particles, analytic fields)
implements one protocol, :class:`Field`:

* ``kind``: the data kind renderers declare they render (``"grid"``, ``"analytic"``, ...);
* ``bounds``: the world-space box ``(lo, hi)`` holding the field (camera framing, ray
  clipping);
* ``value_range``: the smallest and largest value (transfer-function presets, defaults);
* ``sample_spacing``: the world length of "one voxel", the unit of sample distances
  given in voxels (a grid's smallest spacing);
* ``reconstruct(filter, **parameters)``: the continuous field under a reconstruction filter
  (parameters: the Gaussian's ``kernel_width`` and ``kernel_radius``; :func:`reconstruct` passes a scene's), a
  :class:`Reconstruction`: values and gradients at world points, its polynomial
  degree between knots, and the ``knots`` along rays where it is not smooth (the
  converged reference cuts rays there);
* ``default_filter`` (optional): the filter a scene that leaves ``renderer.filter`` at its default
  (``linear``) gets, where the data has a reconstruction of its own (particles: ``m4``);
* ``samples`` and ``reconstruct_values(values, filter)`` (optional): the field's own
  sample values, and other values at the same samples reconstructed alike
  (pre-classification classifies the samples and reconstructs the result).

What only makes sense on a grid (textures, bricking, min-max pyramids, run-length
encoding) lives with the grid renderers (:mod:`dvr_gl.renderers`), not here.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from .analytic import SphereField
from .grid import Volume
from .particles import ParticleSet


@runtime_checkable
class Reconstruction(Protocol):
    """A continuous scalar field: values, gradients and its non-smooth places along rays."""

    degree: int  # polynomial degree along a ray between knots (0: piecewise constant)

    def sample(self, points: np.ndarray) -> np.ndarray:
        """Values at world points ``(N, 3)``: ``(N,)`` float64 (``(N, C)`` for multi-channel values)."""

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """Gradients ``(N, 3)`` in value units per world unit."""

    def knots(self, origins, directions, t0, t1) -> tuple[np.ndarray, np.ndarray]:
        """``(ray_index, t)`` where rays cross a place where the field is not smooth, in ``(t0, t1)``."""


@runtime_checkable
class Field(Protocol):
    """Scalar data in world space (see the module doc)."""

    kind: str
    name: str

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]: ...

    @property
    def value_range(self) -> tuple[float, float]: ...

    @property
    def sample_spacing(self) -> float: ...

    def reconstruct(self, filter: str = "linear") -> Reconstruction: ...

    def describe(self) -> str: ...


def filter_parameters(spec) -> dict:
    """The keyword arguments of ``reconstruct`` beyond the filter's name that renderer settings ``spec``
    give: the Gaussian's width and where it is cut (only a field that offers the Gaussian takes them)."""
    return {"kernel_width": spec.kernel_width, "kernel_radius": spec.kernel_radius} if spec.filter == "gaussian" \
        else {}


def reconstruct(field: Field, spec) -> Reconstruction:
    """``field`` reconstructed as renderer settings ``spec`` ask: their filter, with its parameters."""
    return field.reconstruct(spec.filter, **filter_parameters(spec))


def gradient_epsilon(field: Field) -> float:
    """Gradient magnitude (value units per world unit) below which shading takes the normal as
    zero: 1e-5 of the value scale per voxel, far above float32 rounding noise in homogeneous
    regions and far below any structure worth a normal (conventions, "Shading")."""
    lo, hi = field.value_range
    return 1e-5 * max(abs(lo), abs(hi), hi - lo, 1e-30) / field.sample_spacing


def diagonal(field: Field) -> float:
    """Length of the diagonal of the field's bounding box (world units)."""
    lo, hi = field.bounds
    return float(np.linalg.norm(np.asarray(hi) - np.asarray(lo)))


def value_sample(field, max_values: int = 1 << 22) -> np.ndarray:
    """Values whose distribution is the field's, for histograms and suggested transfer functions: a grid's
    samples, a mesh's values; a volume read out of core gives an even subsample of at most ``max_values``
    (:meth:`dvr_gl.out_of_core.OutOfCoreVolume.subsample`), never its whole voxels."""
    if getattr(field, "out_of_core", False):
        return field.subsample(max_values)
    return np.asarray(field.samples if hasattr(field, "samples") else field.values)


__all__ = ["Field", "Reconstruction", "Volume", "SphereField", "ParticleSet", "gradient_epsilon", "diagonal",
           "value_sample"]
