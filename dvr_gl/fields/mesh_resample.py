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

from ..errors import SceneError
from .grid import Volume

MAX_SAMPLES = 1024  # along the longest axis


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


def resample(mesh, samples: int) -> ResampledMesh:
    """The mesh on a node-centred grid over its box, ``samples`` points along the longest axis (the
    others in proportion, at least 2), as float32."""
    if not 2 <= samples <= MAX_SAMPLES:
        raise SceneError(f"resampling a mesh needs 2 to {MAX_SAMPLES} samples along its longest axis, got {samples}")
    lo, hi = (np.asarray(b, np.float64) for b in mesh.bounds)
    extent = np.maximum(hi - lo, 1e-30)
    spacing = float(extent.max()) / (samples - 1)
    dims = np.maximum(np.ceil(extent / spacing).astype(int) + 1, 2)
    axes = [lo[i] + spacing * np.arange(dims[i]) for i in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    values = mesh.reconstruct().sample(points)
    below = outside_value(mesh)
    values = np.where(np.isnan(values), below, values)
    return ResampledMesh(values.reshape(dims[2], dims[1], dims[0]).astype(np.float32), spacing=(spacing,) * 3,
                         origin=tuple(lo), name=f"{mesh.name} resampled {dims[0]}x{dims[1]}x{dims[2]}",
                         outside_value=float(np.float32(below)), inside_value=float(mesh.value_range[0]))


def resampled_scene(scene, samples: int, volume: ResampledMesh | None = None, **renderer_changes):
    """``scene`` (of a mesh) with the mesh resampled (or ``volume``, its resampling made before), the
    transfer function made transparent at its outside value, the camera kept, and the renderer changed
    as asked (e.g. ``name="raycast"``)."""
    from ..scene import resolve_scene

    volume = resample(scene.field, samples) if volume is None else volume
    resolved = resolve_scene(scene.spec, field=volume, volume_source=scene.volume_source, camera=scene.camera,
                             transfer_function=volume.transparent_outside(scene.transfer_function))
    return resolved.with_renderer(**renderer_changes) if renderer_changes else resolved
