"""``dvr bench scale``: how rendering scales.  Parts: ``workers`` (here: sort-last rendering on a
local Dask cluster against the number of workers, and a model of the scaling to N workers),
``sizes`` (:mod:`.scale_sizes`: time and peak memory against the volume's size) and ``levels``
(:mod:`.scale_levels`: the multi-resolution error).

The workers part renders one frame of a synthetic volume (the blobs phantom, written to a .npy
file so that the workers reload it from disk and only the scene's dict travels) with 1, 2 and as
many workers as there are cores, by both compositing methods, and measures apart:

* the per-brick render cost: each brick's ``render_state`` alone in this process (median of the
  repeats), and their sum, the frame's render work;
* the compositing cost: numpy's combine of two states, seconds per pixel; and the transfers' bytes
  and seconds from the workers' logs (bandwidth);
then fits the model of docs/distributed.md ("Scaling model") to those costs and prints its
prediction for 1 to 256 workers.
"""

from __future__ import annotations

import importlib
import math
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from . import picks

PARTS = ("workers", "sizes", "levels")
STATE_BYTES = 16  # per pixel: 4 float32
MODEL_WORKERS = (1, 2, 4, 8, 16, 32, 64, 128, 256)
# A cluster's network for the model beside the loopback measured here (stated, not measured):
# 10 Gb/s Ethernet, 100 microseconds per message (Dask's own task and transfer latency dominates it).
CLUSTER_BANDWIDTH = 1.25e9
CLUSTER_LATENCY = 1e-4

MEASURED_COLUMNS = [("workers", "workers", "d"), ("method", "method", "s"), ("bricks", "bricks/worker", "s"),
                    ("frame", "frame s", ".3f"), ("render", "render s (slowest worker)", ".3f"),
                    ("composite", "compositing s", ".3f"), ("speedup", "speed-up", ".2f"),
                    ("moved", "moved/worker KiB", ".1f"), ("theory", "theory KiB", ".1f"),
                    ("messages", "messages/worker", "d"), ("client", "to client KiB", ".1f")]
MODEL_COLUMNS = [("workers", "workers", "d"), ("render", "render s", ".4f"),
                 ("direct", "direct send s", ".4f"), ("swap", "binary swap s", ".4f"),
                 ("frame_direct", "frame s (direct)", ".4f"), ("frame_swap", "frame s (swap)", ".4f"),
                 ("speedup", "speed-up (best)", ".1f"), ("efficiency", "efficiency", ".2f")]


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def run(args) -> int:
    """Run ``args.part`` (or every part), printing to ``args.report`` (a :class:`dvr_gl.bench.Report`)."""
    part = getattr(args, "part", None)
    for name in PARTS if part in (None, "all") else (part,):
        if name == "workers":
            run_workers(args)
            continue
        module = f"dvr_gl.bench.scale_{name}"
        try:
            bench = importlib.import_module(module)
        except ModuleNotFoundError as e:
            if e.name != module:
                raise
            args.report.text(f"dvr bench scale --part {name}: not available in this version ({module} is missing)")
            continue
        bench.run(args)
    return 0


def scene_for(folder: Path, volume_size: int, image_size: int):
    """The bench's scene: blobs at ``volume_size``^3 from a .npy file, early termination off (the
    same work in every split), ``image_size`` square."""
    from ..phantoms import blobs
    from ..scene.resolve import load_scene

    path = folder / f"blobs{volume_size}.npy"
    np.save(path, blobs(volume_size).astype(np.float32))
    return load_scene(None, {"volume.path": str(path), "image.width": image_size, "image.height": image_size,
                             "renderer.name": picks.baseline(), "renderer.ert_threshold": 1.0})


def brick_costs(renderer, scene, bricks, repeat: int) -> list[float]:
    """Each brick's render_state seconds alone (median of ``repeat``, after a warm-up)."""
    renderer.render_state(scene, bricks[:1])
    costs = []
    for b in bricks:
        times = []
        for _ in range(repeat):
            started = time.perf_counter()
            renderer.render_state(scene, [b])
            times.append(time.perf_counter() - started)
        costs.append(statistics.median(times))
    return costs


def combine_cost(pixels: int, repeat: int = 5) -> float:
    """numpy's over operator (optical-depth form, the costliest) per pixel, seconds."""
    from ..distributed.composite import combine

    rng = np.random.default_rng(0)
    a, b = (rng.random((pixels, 1, 4), dtype=np.float32) for _ in range(2))
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        combine("over_depth", a, b)
        times.append(time.perf_counter() - started)
    return statistics.median(times) / pixels


def run_workers(args) -> list[dict]:
    from ..distributed import connect, render
    from ..distributed.plan import bricks_for
    from ..renderers import create_renderer

    size = getattr(args, "size", None) or 512
    volume_size = getattr(args, "volume_size", None) or 256
    # One core per worker, as on a cluster of one GPU each: llvmpipe would otherwise spread every
    # process over all cores, and two workers would share what one process already used.
    os.environ.setdefault("LP_NUM_THREADS", "1")
    repeat = getattr(args, "repeat", None) or 3
    counts = getattr(args, "workers", None) or sorted({1, 2, cores()})
    report = args.report
    rows, transfers = [], []
    with tempfile.TemporaryDirectory(prefix="dvr-scale-") as folder, create_renderer(picks.baseline()) as r:
        scene = scene_for(Path(folder), volume_size, size)
        single = []
        r.render(scene)
        for _ in range(repeat):
            r.render(scene)
            single.append(r.stats["seconds"])
        one = statistics.median(single)
        for n in counts:
            with connect(f"local:{n}") as client:
                for method in ("direct_send", "binary_swap"):
                    if method == "binary_swap" and n & (n - 1):
                        continue
                    render(client, scene, method, r)  # warm-up: each worker compiles its programs
                    results = [render(client, scene, method, r) for _ in range(repeat)]
                    med = statistics.median
                    moved = [np.mean(list(x.moved["between_workers"].values())) for x in results]
                    last = results[-1].moved
                    transfers += [(sum(x.moved["between_workers"].values()), sum(x.moved["transfer_seconds"].values()),
                                   sum(x.moved["messages"].values())) for x in results if n > 1]
                    rows.append({"workers": n, "method": method, "bricks": ",".join(map(str, results[-1].bricks)),
                                 "frame": med([x.seconds for x in results]),
                                 "render": med([max(x.render_seconds) for x in results]),
                                 "composite": med([x.composite_seconds for x in results]),
                                 "moved": med(moved) / 1024, "theory": last["theory_per_worker"] / 1024,
                                 "messages": max(last["messages"].values()), "client": last["to_client"] / 1024})
        for row in rows:
            row["speedup"] = one / row["frame"]
        bricks = bricks_for(r, scene, max(counts))
        costs = brick_costs(r, scene, bricks, repeat)
    pixels = size * size
    per_pixel = combine_cost(pixels)
    moved_bytes = sum(t[0] for t in transfers)
    bandwidth = moved_bytes / sum(t[1] for t in transfers) if transfers and sum(t[1] for t in transfers) else math.nan
    report.text(f"dvr bench scale --part workers: blobs {volume_size}^3 (float32, from a .npy file), {size}x{size}, "
                f"emission-absorption, early termination off; a local cluster of processes (one thread each, "
                f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS')}) on {cores()} cores; median of {repeat} "
                f"frames after a warm-up; one process renders it in {one:.3f} s")
    report.table(rows, MEASURED_COLUMNS, notes=[
        "frame: the client's wall clock (plan, the workers' render and compositing, the gather); render: the "
        "slowest worker's render_state; compositing: from the last partial image to the last band composited "
        "(transfers included; the task stream); moved: bytes each worker received from the others (its transfer "
        "log), theory: (N - 1)/N of a state image (16 bytes a pixel) for both methods."])
    report.text(f"measured apart: {len(bricks)} bricks, render_state alone {min(costs) * 1e3:.1f} .. "
                f"{max(costs) * 1e3:.1f} ms, sum {sum(costs):.3f} s; numpy's over operator {per_pixel * 1e9:.1f} "
                f"ns a pixel; loopback transfers {bandwidth / 2 ** 20:.0f} MiB/s "
                f"(messages {sum(t[2] for t in transfers)}, {moved_bytes / 2 ** 20:.1f} MiB)")
    model = scaling_model(sum(costs), pixels, per_pixel, CLUSTER_BANDWIDTH, CLUSTER_LATENCY)
    report.text(f"\nmodel (docs/distributed.md, 'Scaling model'): render work {sum(costs):.3f} s split evenly, "
                f"compositing {per_pixel * 1e9:.1f} ns a pixel, a network of {CLUSTER_BANDWIDTH * 8 / 1e9:.0f} Gb/s "
                f"and {CLUSTER_LATENCY * 1e6:.0f} us a message, one GPU per worker, gather {size}x{size} states "
                f"to the client")
    report.table(model, MODEL_COLUMNS)
    return rows


def scaling_model(render_work: float, pixels: int, per_pixel: float, bandwidth: float, latency: float,
                  workers=MODEL_WORKERS) -> list[dict]:
    """The frame time for N workers (seconds): render_work / N, plus compositing (direct send:
    (N - 1) messages of P/N pixels; binary swap: log2 N messages of P/2, P/4, ... pixels; both
    (N - 1)/N of the image received and combined per worker), plus the gather of one image."""
    rows = []
    image = pixels * STATE_BYTES
    gather = image / bandwidth + latency
    for n in workers:
        share = (n - 1) / n
        receive = share * image / bandwidth + share * pixels * per_pixel
        direct = (n - 1) * latency + receive
        swap = math.log2(n) * latency + receive
        render = render_work / n
        best = min(direct, swap)
        frame_one = render_work + gather
        rows.append({"workers": n, "render": render, "direct": direct, "swap": swap,
                     "frame_direct": render + direct + gather, "frame_swap": render + swap + gather,
                     "speedup": frame_one / (render + best + gather),
                     "efficiency": frame_one / (render + best + gather) / n})
    return rows
