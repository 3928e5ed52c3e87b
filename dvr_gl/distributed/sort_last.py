"""Sort-last rendering on Dask: each worker renders its box of bricks (:mod:`.kd`) to a partial
image (a compositing state), the partial images are composited between the workers by direct send
or binary swap, and the client gathers the composited bands and resolves the image.

Every step is a Dask task pinned to one worker (``workers=[address]``, ``allow_other_workers=False``),
so a band of rows another worker needs really moves between processes; the keys carry a per-frame
tag, so the workers' transfer logs tell what this frame moved (:func:`.cluster.transfers`).

* direct send: worker ``j`` owns band ``j`` of the image's rows (``N`` bands); every worker cuts its
  state into the bands and sends band ``j`` to worker ``j``, which composites the ``N`` pieces in
  the workers' visibility order.  Each worker receives ``N - 1`` pieces of ``1/N`` image.
* binary swap (``N = 2**k``): in round ``r`` worker ``i`` and its kd sibling at that level,
  ``i ^ 2**r``, split the band they both hold in two, each keeps one half and receives the
  other's rows of it, and composites them in the order of the plane that separates their groups.
  Each worker receives ``1/2 + 1/4 + ... + 1/N`` image in ``k`` messages.
Both then send their final band (``1/N`` image) to the client.
"""

from __future__ import annotations

import contextlib
import time
import uuid
from dataclasses import dataclass, field

import numpy as np

from ..renderers import registry
from . import worker as w
from .cluster import place, results, transfers, workers_of
from .plan import check_method, check_scene, plan

BYTES_PER_PIXEL = 16  # a state is 4 float32 per pixel


@dataclass
class Result:
    image: np.ndarray          # (h, w, 4) float32 premultiplied, as a renderer's render
    state: np.ndarray          # the composited state, before the resolve
    method: str
    workers: int
    bricks: list               # bricks per worker
    render_seconds: list       # each worker's render_state time (the renderer's own clock)
    seconds: float             # the whole frame, wall clock on the client
    composite_seconds: float   # from the last partial image rendered to the gathered bands
    moved: dict = field(default_factory=dict)  # measured and theoretical bytes (see :func:`bytes_moved`)


def bands(height: int, count: int) -> list[tuple[int, int]]:
    edges = np.linspace(0, height, count + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def render(client, scene, method: str = "direct_send", renderer=None) -> Result:
    """The frame of ``scene`` rendered on ``client``'s workers (see the module doc).  ``renderer``:
    the client's renderer of the scene (one that composites sort-last, ``RendererPlugin.sort_last``)
    for the plan and the resolve (default: one made and closed here)."""
    addresses = workers_of(client)
    n = len(addresses)
    check_method(method, n)
    check_scene(scene)  # before a renderer is made for it
    from distributed import get_task_stream

    own = renderer is None
    renderer = renderer or registry.plugin(scene.renderer.name).create()
    stack = contextlib.ExitStack()
    try:
        registry.check(scene)
        started = time.perf_counter()
        p = plan(renderer, scene, n)
        tag = uuid.uuid4().hex[:10]
        payload = place(client, w.payload_of(scene), addresses, "scene")
        height, width = scene.image.height, scene.image.width

        def pinned(i, fn, *args, key):
            return client.submit(fn, *args, key=f"dvr-{key}-{tag}", workers=[addresses[i]],
                                 allow_other_workers=False, pure=False)

        stream = stack.enter_context(get_task_stream(client))
        parts = [pinned(i, w.render_part, payload[i], p.bricks[i], p.operator, key=f"part-{i}") for i in range(n)]
        if method == "direct_send":
            finals = _direct_send(pinned, parts, p, height, n)
        else:
            finals = _binary_swap(pinned, parts, p, height, n)
        rendered = results(client, parts)  # the scheduler asked now and then whether it still answers
        gathered = results(client, [f for _, f in finals])
        stack.close()
        seconds = time.perf_counter() - started
        state = np.empty((height, width, 4), np.float32)
        for (lo, hi), band in zip([b for b, _ in finals], gathered):
            state[lo:hi] = band
        image = renderer.resolve_state(scene, state)
        render_seconds = [s for _, s in rendered]
        log = transfers(client, "dvr-")
        del parts, finals, rendered, payload
        moved = bytes_moved(log, tag, addresses, method, height * width * BYTES_PER_PIXEL)
        return Result(image, state, method, n, [len(b) for b in p.bricks], render_seconds, seconds,
                      _composite_seconds(stream.data, tag), moved)
    finally:
        stack.close()
        if own:
            renderer.close()


def _direct_send(pinned, parts, p, height, n):
    spans = bands(height, n)
    finals = []
    for j, (lo, hi) in enumerate(spans):
        pieces = [pinned(i, w.rows, parts[i], lo, hi, key=f"piece-{i}-to-{j}") for i in p.order]
        finals.append(((lo, hi), pinned(j, w.composite, p.operator, *pieces, key=f"band-{j}")))
    return finals


def _binary_swap(pinned, parts, p, height, n):
    tiles = {i: (parts[i], 0, height) for i in range(n)}  # future, first and last + 1 row it covers
    rounds = n.bit_length() - 1
    for r in range(rounds):
        bit = 1 << r
        new = {}
        for i in range(n):
            partner = i ^ bit
            tile, lo, hi = tiles[i]
            mid = (lo + hi) // 2
            keep = (lo, mid) if not i & bit else (mid, hi)
            other, olo, _ = tiles[partner]
            theirs = pinned(partner, w.rows, other, keep[0] - olo, keep[1] - olo, key=f"swap{r}-{partner}-to-{i}")
            group = (i >> (r + 1)) << (r + 1)  # the parent's workers [group, group + 2 bit)
            lower_in_front = p.front_first(group, group + bit, group + 2 * bit)
            mine_in_front = lower_in_front == (not i & bit)
            final = r == rounds - 1
            new[i] = (pinned(i, w.swap, p.operator, tile, keep[0] - lo, keep[1] - lo, theirs, mine_in_front,
                             key=f"band-{i}" if final else f"tile{r}-{i}"), *keep)
        tiles = new
    if rounds == 0:
        return [((0, height), pinned(0, w.rows, parts[0], 0, height, key="band-0"))]
    return [((lo, hi), f) for f, lo, hi in (tiles[i] for i in range(n))]


def _composite_seconds(stream: list, tag: str) -> float:
    """From the end of the last partial image to the end of the last band (seconds): the
    compositing's span, transfers included, from the task stream (worker clocks)."""
    def stops(prefix):
        return [max(ss["stop"] for ss in t["startstops"]) for t in stream
                if str(t["key"]).startswith(prefix) and str(t["key"]).endswith(tag) and t.get("startstops")]
    parts, bands_done = stops("dvr-part-"), stops("dvr-band-")
    return max(bands_done) - max(parts) if parts and bands_done else float("nan")


def bytes_moved(log: dict, tag: str, addresses: list, method: str, image_bytes: int) -> dict:
    """What the frame moved, from the workers' transfer logs, beside the theory:
    ``between_workers`` (each worker's received bytes), ``to_client`` (the final bands), and
    ``theory_per_worker`` = ``(N - 1) / N`` image for both methods (direct send: ``N - 1`` pieces
    of ``1/N``; binary swap: ``1/2 + ... + 1/N``), ``theory_to_client`` = one image."""
    n = len(addresses)
    incoming = {a: sum(e[1] for e in log[a]["incoming"] if e[0].endswith(tag)) for a in addresses}
    messages = {a: sum(1 for e in log[a]["incoming"] if e[0].endswith(tag)) for a in addresses}
    seconds = {a: sum(e[3] for e in log[a]["incoming"] if e[0].endswith(tag)) for a in addresses}
    to_client = sum(e[1] for a in addresses for e in log[a]["outgoing"]
                    if e[0].endswith(tag) and e[0].startswith("dvr-band-") and e[2] not in addresses)
    return {"image_bytes": image_bytes, "between_workers": incoming, "messages": messages,
            "transfer_seconds": seconds,
            "to_client": to_client, "theory_per_worker": image_bytes * (n - 1) / n,
            "theory_messages_per_worker": (n - 1) if method == "direct_send" else n.bit_length() - 1,
            "theory_to_client": image_bytes}
