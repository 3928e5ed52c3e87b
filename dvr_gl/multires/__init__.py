"""Multi-resolution: pyramids of a volume and the choice of a level per brick.

* :mod:`.downsample`: one halving with a low-pass filter (the tent ``[1 2 1] / 4`` on the nodes,
  the node-centred convention kept: origin kept, spacing doubled);
* :mod:`.pyramid`: :func:`build_levels` in memory, :func:`write_pyramid` to an OME-Zarr image (NGFF 0.4)
  in bounded memory;
* :mod:`.lod`: :func:`choose_levels`, the coarsest level whose voxel projects to at most a given number of
  pixels at each brick (screen-space error);
* :mod:`.accuracy`: :func:`level_errors`, each level rendered against the full resolution.

``docs/multiresolution.md`` has the choices and the measurements.
"""

from .accuracy import level_errors, predicted_error
from .downsample import KERNELS, TENT, Kernel, downsample
from .lod import choose_levels, voxel_pixels
from .pyramid import build_levels, level_plan, write_pyramid

__all__ = ["TENT", "KERNELS", "Kernel", "build_levels", "choose_levels", "downsample", "level_errors",
           "level_plan", "predicted_error", "voxel_pixels", "write_pyramid"]
