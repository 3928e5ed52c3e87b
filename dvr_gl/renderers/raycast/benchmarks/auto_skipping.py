"""Is "auto" empty-space skipping on the faster side?  Block skipping on against off over sample distances.

    python dvr_gl/renderers/raycast/benchmarks/auto_skipping.py [--data-dir ../shared/data] [--size 512] [--repeat 5]

For each scene and sample distance (0.5 to 8 voxels): the frame time without acceleration (off),
with the ray bounds alone where they apply (emission-absorption; elsewhere this is off), and with
the bounds and block skipping in the loop (on), alternating frames, median of ``repeat`` each, one
process; the estimate behind "auto"'s in-loop decision (`acceleration.skip_estimate` over the points
inside the bounds: the fraction of samples saved and block lookups per ray), the lookup cost at
which it breaks even (``break-even C``: skipping is estimated cheaper when ``renderer.LOOKUP_COST``
of the mode is below it), what "auto" chose and its frame against the faster of bounds and on.
``renderer.LOOKUP_COST`` is chosen so that "auto" is right wherever the two differ by more than 5 %.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
import time
from pathlib import Path

from dvr_gl.bench import peers
from dvr_gl.renderers.raycast import renderer as raycast
from dvr_gl.renderers.raycast.renderer import LOOKUP_COST, RayCastRenderer
from dvr_gl.scene.resolve import load_scene

DISTANCES = (0.5, 1.0, 2.0, 4.0, 8.0)


def scenes(data_dir: Path, size: int, work: Path) -> list[tuple[str, dict]]:
    out = []
    for key in ("ml-composite", "ml-mip", "blobs-composite", "blobs-mip"):
        out.append((key, peers.scene_keys(key, peers.volume_file(peers.SCENES[key][0], 256, work), size)))
    found = peers.dataset_file("cthead", data_dir, work)
    if found:
        out.append(("cthead-bone", peers.scene_keys("cthead-bone", found[0], size, found[1])))
    hu = {"transfer_function.preset": "ct-bone-ivory", "transfer_function.rescale_intercept": -1024.0,
          "image.width": size, "image.height": size, "camera.azimuth": 30.0, "camera.elevation": 20.0}
    for name, path in (("bunny-bone", "large/bunny_ct.nhdr"), ("lobster", "regular/lobster.nhdr")):
        if (data_dir / path).exists():
            extra = {"transfer_function.preset": "viridis"} if name == "lobster" else hu
            out.append((name, {"volume.path": str(data_dir / path), "image.width": size, "image.height": size,
                               "camera.azimuth": 30.0, "camera.elevation": 20.0, **extra}))
    return out


@contextlib.contextmanager
def bounds_only():
    """auto with the ray bounds wherever they apply and no block skipping in the loop."""
    saved = raycast.AUTO_BOUNDS_COST, raycast.worth_skipping
    raycast.AUTO_BOUNDS_COST, raycast.worth_skipping = 0.0, lambda estimate, sample_distance: False
    try:
        yield
    finally:
        raycast.AUTO_BOUNDS_COST, raycast.worth_skipping = saved


def render_as(renderer, scene, name):
    if name == "bounds":
        with bounds_only():
            return renderer.render(scene)
    return renderer.render(scene.with_renderer(acceleration=name))


def measure(renderer, scene, repeat: int) -> dict:
    names = ("on", "bounds", "off")
    for name in names:
        render_as(renderer, scene, name)
    times = {name: [] for name in names}
    for _ in range(repeat):
        for name in names:
            start = time.perf_counter()
            render_as(renderer, scene, name)
            times[name].append(time.perf_counter() - start)
    renderer.render(scene)
    stats = renderer.stats
    return {**{name: 1e3 * statistics.median(t) for name, t in times.items()},
            "auto": "on" if stats["accelerated"] else "bounds", "estimate": renderer._skippable[1]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data-dir", default=str(Path(__file__).resolve().parents[5] / "shared" / "data"))
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--only", help="scenes whose name contains this")
    args = p.parse_args(argv)
    work = tempfile.TemporaryDirectory(prefix="dvr-auto-")
    renderer = RayCastRenderer()
    print(f"LOOKUP_COST {LOOKUP_COST}")
    print("scene | voxels | outside bounds (est.) | saved inside (est.) | lookups/ray (est.) | break-even C | "
          "off ms | bounds ms | on ms | auto | auto / faster of bounds and on")
    wrong = 0
    for name, keys in scenes(Path(args.data_dir), args.size, Path(work.name)):
        if args.only and args.only not in name:
            continue
        base = load_scene(None, keys)
        spacing = min(base.volume.spacing)
        for voxels in DISTANCES:
            scene = base.with_renderer(sample_distance=voxels * spacing)
            m = measure(renderer, scene, args.repeat)
            est = m["estimate"]
            samples = est.length / scene.renderer.sample_distance
            breakeven = est.fraction * samples / est.lookups if est.lookups else float("inf")
            ratio = m[m["auto"]] / min(m["on"], m["bounds"])
            wrong += ratio > 1.05
            print(f"{name} | {voxels:g} | {est.outside:.2f} | {est.fraction:.2f} | {est.lookups:.1f} | "
                  f"{breakeven:.2f} | {m['off']:.0f} | {m['bounds']:.0f} | {m['on']:.0f} | {m['auto']} | {ratio:.2f}",
                  flush=True)
    print(f"auto more than 5 % slower than the faster of bounds and on: {wrong} cases")
    return 0


if __name__ == "__main__":
    sys.exit(main())
