"""Shear-warp's bench: ``dvr bench shearwarp``, the run-length encoding's build and the frame time on the
shared datasets with 50, 90 and 99 % transparent voxels, against the GPU ray caster (:mod:`.measure`).
Declared by the plugin (``bench=``); the measurement is imported when run.
"""

from __future__ import annotations

from ...bench_command import BenchCommand, on_shared_data, shared_data_arguments


def _run(args) -> int:
    from . import measure

    return on_shared_data(args, measure, f"dvr bench shearwarp: {args.size}x{args.size} images, pre-classified "
                          f"opacity ramps from the 50, 90 and 99 % quantiles, default view, {args.repeat} timed "
                          f"frames per case after a warm-up; raycast at 0.5-voxel steps with early termination "
                          f"and empty-space skipping")


COMMANDS = (BenchCommand("shearwarp", "shear-warp on the datasets in ../shared/data: encoding, frame time, voxels "
                         "skipped, against raycast", shared_data_arguments, _run),)
