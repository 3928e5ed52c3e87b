"""Whole frames on Dask: an animation's frames, one task each, dealt round-robin to the workers
(pinned, so that every worker draws); the scene travels once per worker (:func:`.worker.payload_of`)."""

from __future__ import annotations

from collections.abc import Iterator

from . import worker as w
from .cluster import place, results, workers_of
from .plan import check_scene


def render_frames(client, scene, cameras: list, ahead: int | None = None) -> Iterator:
    """``(image, seconds)`` for each camera, in order (image: the renderer's premultiplied RGBA,
    as the scene's renderer's ``render``; seconds: the worker's render time).  At most ``ahead``
    frames (default two per worker) are in flight or waiting to be taken, so a long animation
    never holds all its frames in memory."""
    check_scene(scene)
    addresses = workers_of(client)
    ahead = ahead or 2 * len(addresses)
    payload = place(client, w.payload_of(scene), addresses, "scene")
    pending = []

    def submit(k):
        i = k % len(addresses)
        pending.append(client.submit(w.render_frame, payload[i], cameras[k], key=f"dvr-frame-{k}-{id(pending)}",
                                     workers=[addresses[i]], allow_other_workers=False, pure=False))

    for k in range(min(ahead, len(cameras))):
        submit(k)
    for k in range(len(cameras)):
        future = pending.pop(0)
        if k + ahead < len(cameras):
            submit(k + ahead)
        yield results(client, [future])[0]  # the scheduler asked now and then whether it still answers
        del future
