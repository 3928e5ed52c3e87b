"""The entry points of ``dvr render --dask`` and ``dvr_gl.render(dask=...)``: the frames of a render
drawn on a cluster, as the single-process loop would draw them."""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator

from ..errors import DvrError
from .cluster import connect
from .frames import render_frames
from .plan import METHODS, check_scene
from .sort_last import render

log = logging.getLogger(__name__)


def check_request(scene, method: str) -> None:
    """One line, before any worker starts, for what cannot be rendered on Dask."""
    if method not in METHODS:
        raise DvrError(f"compositing method {method!r}: use one of {', '.join(METHODS)}")
    check_scene(scene)


@contextlib.contextmanager
def frames_on(dask, frames: list, method: str = "direct_send", renderer=None) -> Iterator:
    """An iterator of the premultiplied RGBA images of ``frames`` (scenes that differ only in the
    camera), rendered on ``dask`` (``local:N``, an address or a Client): one frame by sort-last
    compositing of its bricks; several, one whole frame per task."""
    check_request(frames[0], method)
    with connect(dask) as client:
        if len(frames) == 1:
            yield _one(client, frames[0], method, renderer)
        else:
            yield (image for image, _ in render_frames(client, frames[0], [f.camera for f in frames]))


def _one(client, scene, method, renderer):
    result = render(client, scene, method, renderer)
    moved = result.moved
    log.info("%s on %d workers (%s bricks): %.2f s, compositing %.3f s; moved between workers %s bytes "
             "(theory %.0f each), to the client %d bytes", method, result.workers, result.bricks, result.seconds,
             result.composite_seconds, sorted(moved["between_workers"].values()), moved["theory_per_worker"],
             moved["to_client"])
    yield result.image


def render_image(scene, dask, method: str = "direct_send", renderer=None):
    """``(image, stats)``: one frame of ``scene`` by sort-last rendering on ``dask``."""
    check_request(scene, method)
    with connect(dask) as client:
        result = render(client, scene, method, renderer)
    stats = {"seconds": result.seconds, "workers": result.workers, "bricks": result.bricks,
             "compositing_method": method, "render_seconds": result.render_seconds,
             "composite_seconds": result.composite_seconds, "bytes_moved": result.moved}
    return result.image, stats
