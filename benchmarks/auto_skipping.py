"""Is "auto" empty-space skipping on the faster side?  Skipping on against off over sample distances.

    python benchmarks/auto_skipping.py [--data-dir ../shared/data] [--size 512] [--repeat 5]

For each scene and sample distance (0.5 to 8 voxels): the frame time with skipping forced on and off
(alternating frames, median of ``repeat`` each, one process), the estimate behind "auto"
(`acceleration.skip_estimate`: the fraction of samples saved and block lookups per ray), the lookup
cost at which the estimate breaks even (``break-even C``: skipping is estimated cheaper when
``renderer.LOOKUP_COST`` of the mode is below it), what "auto" chose and its frame against the
faster of the two.  ``renderer.LOOKUP_COST`` is chosen so that "auto" is right wherever on and off
differ by more than 5 %.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from dvr_gl.bench import peers
from dvr_gl.renderers.raycast.renderer import LOOKUP_COST, RayCastRenderer
from dvr_gl.scene import load_scene

DISTANCES = (0.5, 1.0, 2.0, 4.0, 8.0)


def scenes(data_dir: Path, size: int, work: Path) -> list[tuple[str, dict]]:
    out = []
    for key in ("ml-composite", "ml-mip", "blobs-composite", "blobs-mip"):
        out.append((key, peers.scene_keys(key, peers.volume_file(peers.SCENES[key][0], 256, work), size)))
    found = peers.dataset_file("cthead", data_dir, work)
    if found:
        out.append(("cthead-bone", peers.scene_keys("cthead-bone", found[0], size, found[1])))
    hu = {"transfer_function.preset": "ct-bone", "transfer_function.rescale_intercept": -1024.0,
          "image.width": size, "image.height": size, "camera.azimuth": 30.0, "camera.elevation": 20.0}
    for name, path in (("bunny-bone", "large/bunny_ct.nhdr"), ("lobster", "regular/lobster.nhdr")):
        if (data_dir / path).exists():
            extra = {"transfer_function.preset": "viridis"} if name == "lobster" else hu
            out.append((name, {"volume.path": str(data_dir / path), "image.width": size, "image.height": size,
                               "camera.azimuth": 30.0, "camera.elevation": 20.0, **extra}))
    return out


def measure(renderer, scene, repeat: int) -> dict:
    on, off = scene.with_renderer(acceleration="on"), scene.with_renderer(acceleration="off")
    renderer.render(on)
    renderer.render(off)
    times = {"on": [], "off": []}
    for _ in range(repeat):
        for name, s in (("on", on), ("off", off)):
            start = time.perf_counter()
            renderer.render(s)
            times[name].append(time.perf_counter() - start)
    renderer.render(scene)
    stats = renderer.stats
    return {"on": 1e3 * statistics.median(times["on"]), "off": 1e3 * statistics.median(times["off"]),
            "auto": "on" if stats["accelerated"] else "off", "estimate": renderer._skippable[1]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data-dir", default=str(Path(__file__).resolve().parents[2] / "shared" / "data"))
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--only", help="scenes whose name contains this")
    args = p.parse_args(argv)
    work = tempfile.TemporaryDirectory(prefix="dvr-auto-")
    renderer = RayCastRenderer()
    print(f"LOOKUP_COST {LOOKUP_COST}")
    print("scene | voxels | saved (est.) | lookups/ray (est.) | break-even C | on ms | off ms | faster | auto | "
          "auto / faster")
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
            faster = "on" if m["on"] < m["off"] else "off"
            ratio = m[m["auto"]] / min(m["on"], m["off"])
            wrong += ratio > 1.05
            print(f"{name} | {voxels:g} | {est.fraction:.2f} | {est.lookups:.1f} | {breakeven:.2f} | {m['on']:.0f} | "
                  f"{m['off']:.0f} | {faster} | {m['auto']} | {ratio:.2f}", flush=True)
    print(f"auto more than 5 % slower than the faster side: {wrong} cases")
    return 0


if __name__ == "__main__":
    sys.exit(main())
