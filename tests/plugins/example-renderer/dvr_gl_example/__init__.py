"""``cpu-projection``: maximum, minimum and average intensity projection on the CPU, in numpy.

An example of a renderer living in its own package: it declares itself in :data:`PLUGIN` (the
settings it reads, the modes it supports, the data kinds it renders, its oracle, its trade-off
sweep and its promises against the closed forms) and registers it in its ``pyproject.toml``::

    [project.entry-points."dvr_gl.renderers"]
    cpu-projection = "dvr_gl_example:PLUGIN"

It samples the conventions' segments (length ``sample_distance``, the last shortened, each at its
midpoint), reconstructs the field there through the field protocol (so it renders any data kind,
grids and analytic fields alike), and keeps the running maximum, minimum or length-weighted mean
per ray; the projected value is classified once through the transfer-function table, with the
opacity of one ``unit_distance``, as the conventions say.  Its oracle is dvr-gl's
same-discretization reference.
"""

from __future__ import annotations

import numpy as np

from dvr_gl.rays import RayBatch, segment_counts
from dvr_gl.renderers import Renderer, RendererPlugin
from dvr_gl.scene import settings as s
from dvr_gl.scene import sweeps


class ProjectionRenderer(Renderer):
    name = "cpu-projection"
    description = "CPU maximum, minimum and average intensity projection (an example plugin)"

    def draw(self, scene) -> np.ndarray:
        r, field = scene.renderer, scene.field
        width, height = scene.image.width, scene.image.height
        rays = RayBatch.for_camera(scene.camera, width, height, field.bounds)
        count = segment_counts(rays.t0, rays.t1, r.sample_distance)
        value_field = field.reconstruct(r.filter)
        mode = r.compositing
        acc = np.full(len(count), {"mip": -np.inf, "minip": np.inf, "average": 0.0}[mode])
        for k in range(int(count.max(initial=0))):
            rows = np.nonzero(count > k)[0]
            start = rays.t0[rows] + k * r.sample_distance
            length = np.minimum(r.sample_distance, rays.t1[rows] - start)
            values = value_field.sample(rays.points(rows, (start + 0.5 * length)[:, None]))
            if mode == "mip":
                acc[rows] = np.maximum(acc[rows], values)
            elif mode == "minip":
                acc[rows] = np.minimum(acc[rows], values)
            else:
                acc[rows] += values * length
        hit = count > 0
        if mode == "average":
            acc[hit] /= (rays.t1 - rays.t0)[hit]
        colour, sigma = scene.transfer_function.tabulate(r.lut_size).lookup(acc[hit])
        alpha = -np.expm1(-sigma * scene.transfer_function.unit_distance)
        rgba = np.zeros((len(count), 4))
        rgba[hit, :3] = colour * alpha[:, None]
        rgba[hit, 3] = alpha
        self.stats = {"samples": int(count.sum())}
        return rgba.reshape(height, width, 4).astype(np.float32)


PLUGIN = RendererPlugin(
    name="cpu-projection",
    description=ProjectionRenderer.description,
    renderer=ProjectionRenderer,
    settings=(s.SAMPLE_DISTANCE, s.SAMPLE_DISTANCE_VOXELS, s.COMPOSITING.only("mip", "minip", "average"),
              s.FILTER, s.LUT_SIZE),
    data_kinds=("grid", "analytic"),  # fields defined everywhere in their box (a mesh's scalar is NaN in its gaps)
    oracle="dvr_gl_example.oracle:oracle",
    sweeps=(sweeps.POST, sweeps.NEAREST, sweeps.LUT_SIZE),
    # Against the closed forms (measured as dvr-gl's own same-discretization reference, float64): 3e-8;
    # MIP and MinIP of the ramp take the extreme sample, half a segment inside the chord's end: 0.015.
    tolerances={"box": 1e-6, "ramp": 1e-6, ("ramp", "mip"): 0.02, ("ramp", "minip"): 0.02, "sphere": 1e-6},
)
