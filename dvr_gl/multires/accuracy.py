"""The error of each pyramid level against the full resolution, measured and predicted.

Each level is rendered as a whole volume in the scene's place (same camera, transfer function, image
and sample distance in world units, so that only the data differ) and compared with level 0's image:
RMS and maximum absolute difference over the premultiplied linear RGBA pixels.  The prediction is the
projected voxel size (:func:`.lod.voxel_pixels`, at the box's point nearest the eye): the level
selection rule (:mod:`.lod`) takes a level where it is at most one pixel, and :func:`predicted_error`
extrapolates level 1's measured error in proportion to the voxel size (measured exponents from level 1
to 2 spread from 0.5 to 1.7 over the demos and datasets, around 1; a filter's error on a smooth field
would be second order, but the transfer function's narrow bands and thin features make the image's
error nearer first order, and it saturates once a feature is below the level's resolution:
``docs/multiresolution.md``).
"""

from __future__ import annotations

import numpy as np

from .lod import nearest_distance, voxel_pixels


def level_scene(scene, level):
    """``scene`` with ``level`` as its volume: the same camera and the same sample distance (world units)."""
    d = scene.renderer.sample_distance
    return scene.replace(volume=level, camera=scene.camera).with_renderer(sample_distance=d)


def level_errors(scene, levels, renderer: str | None = None, ctx=None) -> list[dict]:
    """For each of ``levels`` (level 0, the scene's full resolution, first): ``level``, ``dims``,
    ``bytes``, ``voxel_px`` (one voxel projected at the box's point nearest the eye), ``rms`` and
    ``max`` (its image against level 0's; 0 for level 0) and ``predicted`` (:func:`predicted_error`).
    ``renderer``: a registered renderer's name (default: the scene's; a judge, ``RendererPlugin.reference``,
    tells the model's error from the GPU's)."""
    from ..orientation import volume_frame_scene
    from ..renderers import create_renderer

    camera = volume_frame_scene(scene)[0].camera
    distance = nearest_distance(levels[0].box, camera.eye)
    height = scene.image.height
    rows, images = [], []
    with create_renderer(renderer or scene.renderer.name, ctx=ctx) as r:
        for index, level in enumerate(levels):
            image = np.asarray(r.render(level_scene(scene, level)), dtype=np.float64)
            images.append(image)
            diff = image - images[0]
            rows.append({"level": index, "dims": "x".join(map(str, level.dims)),
                         "bytes": int(np.prod(level.dims)) * np.dtype(level.dtype).itemsize,
                         "voxel_px": voxel_pixels(level, camera, height, distance),
                         "rms": float(np.sqrt(np.mean(diff ** 2))), "max": float(np.abs(diff).max())})
    predicted = predicted_error([row["voxel_px"] for row in rows], rows[1]["rms"] if len(rows) > 1 else 0.0)
    for row, p in zip(rows, predicted):
        row["predicted"] = p
    return rows


def predicted_error(voxel_px, level1_rms: float, power: float = 1.0) -> list[float]:
    """The RMS error each level is predicted to have from its projected voxel size ``voxel_px`` (level 0
    first): 0 for level 0, level 1's measured ``level1_rms`` times ``(px / px_1) ** power``."""
    if len(voxel_px) < 2:
        return [0.0] * len(voxel_px)
    return [0.0] + [level1_rms * (px / voxel_px[1]) ** power for px in voxel_px[1:]]
