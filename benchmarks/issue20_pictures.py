"""Pictures of clipping and of shaded shear-warp for the docs.

    python benchmarks/issue20_pictures.py [--size 256] [--data-dir ../shared/data] [--out docs/images]

* ``clipping.png``: the blobs demo (64^3, shaded) cut by a plane facing the default eye through the
  centre and cropped by a box, left to right: the ray caster, slicing3d, and the reference of the
  ray caster's own segments (``reference``); below, 10x the ray caster's difference from it.
* ``shearwarp-shaded.png``: CThead (skin preset, from the shared data when present, else the Marschner-
  Lobb demo), left to right: the ray caster shaded per sample, shear-warp shaded by its tables over
  quantized normals, shear-warp unshaded; the frame times are printed (one frame each on this
  machine, shear-warp's encodings and normals made in a first frame that is not counted).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from dvr_gl.image import side_by_side, write_image
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.renderers import create_renderer
from dvr_gl.scene import load_scene

REPO = Path(__file__).resolve().parent.parent


def _timed(renderer, scene, label: str) -> np.ndarray:
    renderer.render(scene)  # the encodings, normals and textures are made once, not counted
    start = time.perf_counter()
    image = renderer.render(scene)
    print(f"  {label}: {time.perf_counter() - start:.2f} s")
    return image


def clipping(size: int) -> np.ndarray:
    base = load_scene(None, {"volume.demo": "blobs", "volume.size": 64, "image.width": size, "image.height": size,
                             "renderer.shading.enabled": True})
    forward = np.asarray(base.camera.basis()[0])
    lo, hi = (np.asarray(b) for b in base.field.bounds)
    centre = (lo + hi) / 2.0
    span = hi - lo
    clip = {"planes": [[*forward, -float(forward @ centre)]],
            "box": [list(lo - 1.0), list(centre + [0.3 * span[0], 0.5 * span[1] + 1.0, 0.25 * span[2]])]}
    scene = base.with_renderer(clipping=type(base.renderer.clipping)(planes=[tuple(p) for p in clip["planes"]],
                                                                    box=tuple(tuple(c) for c in clip["box"])))
    print("clipping (blobs 64^3):")
    top = []
    for name in ("raycast", "slicing3d"):
        with create_renderer(name) as renderer:
            top.append(_timed(renderer, scene.with_renderer(name=name), name))
    start = time.perf_counter()
    truth = DiscreteReference(scene.with_renderer(name="reference")).render_float64()
    print(f"  reference: {time.perf_counter() - start:.1f} s; raycast RMS against it "
          f"{np.sqrt(np.mean((top[0] - truth) ** 2)):.1e}")
    top.append(truth.astype(np.float32))
    difference = np.minimum(10.0 * np.abs(top[0] - truth).sum(axis=-1), 1.0)
    grey = np.stack([difference] * 3 + [np.ones_like(difference)], axis=-1).astype(np.float32)
    blank = np.zeros_like(grey)
    return side_by_side([side_by_side(top), side_by_side([grey, blank, blank])], axis=0)


def shaded_shearwarp(size: int, data_dir: Path) -> np.ndarray:
    path = data_dir / "regular" / "cthead.nhdr"
    if path.exists():
        scene = load_scene(None, {"volume.path": str(path), "transfer_function.preset": "ct-skin",
                                  "camera.up": [0, 0, -1], "image.width": size, "image.height": size,
                                  "renderer.shading.enabled": True})
        label = "CThead"
    else:
        scene = load_scene(None, {"volume.demo": "marschner-lobb", "volume.size": 64, "image.width": size,
                                  "image.height": size, "renderer.shading.enabled": True})
        label = "Marschner-Lobb 64^3"
    print(f"shear-warp shaded ({label}):")
    with create_renderer("raycast") as raycast, create_renderer("shearwarp") as shearwarp:
        pictures = [_timed(raycast, scene.with_renderer(name="raycast"), "raycast, shaded"),
                    _timed(shearwarp, scene.with_renderer(name="shearwarp"), "shearwarp, shaded by tables"),
                    _timed(shearwarp, scene.with_renderer(name="shearwarp", shading=type(scene.renderer.shading)(
                        enabled=False)), "shearwarp, unshaded")]
    return side_by_side(pictures)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--data-dir", default=str(REPO.parent / "shared" / "data"))
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = p.parse_args(argv)
    out = Path(args.out)
    write_image(out / "clipping.png", clipping(args.size), overwrite=True)
    write_image(out / "shearwarp-shaded.png", shaded_shearwarp(args.size, Path(args.data_dir)), overwrite=True)
    print(f"wrote {out / 'clipping.png'} and {out / 'shearwarp-shaded.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
