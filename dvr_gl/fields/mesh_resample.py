"""A tetrahedral mesh resampled onto a regular grid, so that every grid renderer can render it.

Each grid point takes the mesh's value there (barycentric interpolation in the cell that holds it,
found by :class:`~dvr_gl.fields.mesh_locate.CellLocator`).  Grid points outside every cell (a
non-convex mesh's concavities, the rest of its box) get :func:`outside_value`, just below the
scalar's range, and the scene's transfer function gains a transparent control point there
(:func:`resampled_scene`): so the grid renderers see no material outside the mesh, and its
boundary becomes a steep, one-voxel-wide fall of opacity, not a hard edge.  The error against the
mesh reference falls with the resolution (``dvr bench cells``, ``docs/meshes.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import limits, progress
from ..errors import SceneError
from ..sandbox import check_bytes
from .grid import Volume
from .mesh_locate import BYTES_PER_CANDIDATE, CANDIDATES_PER_CHUNK

MAX_SAMPLES = 1024  # along the longest axis
POINTS_PER_SLAB = 1 << 18      # grid points located at once (their coordinates, cells and values)
BYTES_PER_SLAB_POINT = 96      # a slab's float64 coordinates, cell indices, values and the mask
RESAMPLE_WORK = "point-in-cell tests"  # the unit of limits.BOUNDS resampling counts


def outside_value(mesh) -> float:
    """The value given to grid points outside the mesh: a thousandth of the range below it."""
    lo, hi = mesh.value_range
    return lo - 1e-3 * max(hi - lo, abs(lo), 1e-30)


@dataclass(frozen=True, eq=False, repr=False)
class ResampledMesh(Volume):
    """A mesh on a grid: a :class:`Volume` whose points outside every cell hold ``outside_value``, below
    the mesh's scalar range (its lowest value ``inside_value``); a scene makes its transfer function
    transparent there (:meth:`~dvr_gl.transfer_function.TransferFunction.transparent_below`)."""

    outside_value: float = float("-inf")
    inside_value: float = float("-inf")

    def transparent_outside(self, tf):
        """``tf`` unchanged over the mesh's values, transparent at and below the outside value."""
        return tf.transparent_below(self.outside_value, self.inside_value)


def grid_of(mesh, samples: int):
    """``(lo, spacing, dims)`` of the node-centred grid over the mesh's box with ``samples`` points along
    its longest axis (the others in proportion, at least 2); ``dims`` is (x, y, z)."""
    if not 2 <= samples <= MAX_SAMPLES:
        raise SceneError(f"resampling a mesh needs 2 to {MAX_SAMPLES} samples along its longest axis, got {samples}")
    lo, hi = (np.asarray(b, np.float64) for b in mesh.bounds)
    extent = np.maximum(hi - lo, 1e-30)
    spacing = float(extent.max()) / (samples - 1)
    dims = np.maximum(np.ceil(extent / spacing).astype(int) + 1, 2)
    return lo, spacing, dims


def check_resample(mesh, samples: int, locator=None) -> float:
    """Refuse, before anything is allocated, a resampling whose grid exceeds the memory budget (the
    float32 grid, a slab's temporaries and the locator's chunk) or whose candidate tests exceed
    the bound of ``limits.BOUNDS`` (lowered by ``max_seconds``); the count of tests (0 without ``locator``)."""
    _, _, dims = grid_of(mesh, samples)
    points = float(np.prod(dims.astype(np.float64)))
    size = "x".join(map(str, dims))
    check_bytes(points * 4.0 + POINTS_PER_SLAB * BYTES_PER_SLAB_POINT + CANDIDATES_PER_CHUNK * BYTES_PER_CANDIDATE,
                f"resampling {mesh.name} onto {size} points (volume.resample = {samples})",
                "lower --resample (volume.resample)")
    if locator is None:
        return 0.0
    lo, spacing, dims = grid_of(mesh, samples)
    work = locator.candidates_on_grid([lo[i] + spacing * np.arange(dims[i]) for i in range(3)])
    limits.check_work(limits.Work(work, RESAMPLE_WORK, f"{mesh.name} onto {size} points, volume.resample = "
                                  f"{samples}", "lower --resample (volume.resample), or render the mesh itself "
                                  "(with a renderer of meshes)"), "resampling")
    return work


def resample(mesh, samples: int) -> ResampledMesh:
    """The mesh on a node-centred grid over its box, ``samples`` points along the longest axis (the
    others in proportion, at least 2), as float32; checked first (:func:`check_resample`), located slab
    by slab with progress."""
    check_resample(mesh, samples)
    reconstruction = mesh.reconstruct()
    check_resample(mesh, samples, reconstruction.locator)
    lo, spacing, dims = grid_of(mesh, samples)
    axes = [lo[i] + spacing * np.arange(dims[i]) for i in range(3)]
    below = outside_value(mesh)
    out = np.empty((dims[2], dims[1], dims[0]), np.float32)
    per_slab = max(1, POINTS_PER_SLAB // int(dims[0] * dims[1]))
    with progress.task("resampling", int(dims[2]), "slice") as step:
        for z0 in range(0, dims[2], per_slab):
            z, y, x = np.meshgrid(axes[2][z0:z0 + per_slab], axes[1], axes[0], indexing="ij")
            values = reconstruction.sample(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1))
            out[z0:z0 + per_slab] = np.where(np.isnan(values), below, values).reshape(x.shape)
            step(min(z0 + per_slab, int(dims[2])))
    return ResampledMesh(out, spacing=(spacing,) * 3,
                         origin=tuple(lo), name=f"{mesh.name} resampled {dims[0]}x{dims[1]}x{dims[2]}",
                         outside_value=float(np.float32(below)), inside_value=float(mesh.value_range[0]))


def resampled_scene(scene, samples: int, volume: ResampledMesh | None = None, **renderer_changes):
    """``scene`` (of a mesh) with the mesh resampled (or ``volume``, its resampling made before), the
    transfer function made transparent at its outside value, the camera kept, and the renderer changed
    as asked (e.g. ``name=`` a renderer of grids).  The scene re-resolves itself around the new field
    (:meth:`dvr_gl.scene.resolve.Scene.replace`): the fields sit below the scene contract and import none of it."""
    volume = resample(scene.field, samples) if volume is None else volume
    resolved = scene.replace(field=volume, volume_source=scene.volume_source, camera=scene.camera,
                             transfer_function=volume.transparent_outside(scene.transfer_function))
    return resolved.with_renderer(**renderer_changes) if renderer_changes else resolved
