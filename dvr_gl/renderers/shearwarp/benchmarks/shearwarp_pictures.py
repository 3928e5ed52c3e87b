"""Pictures of shear-warp for its page (README.md in this folder), beside the default grid renderer.

    python dvr_gl/renderers/shearwarp/benchmarks/shearwarp_pictures.py [--size 256] \
        [--data-dir ../shared/data] [--out docs/images]

* ``shearwarp-shaded.png``: CThead with the bone preset, left to right: the default grid renderer (the ray
  caster) shaded per sample, shear-warp shaded by its tables over quantized normals, shear-warp unshaded.
* ``shearwarp-inside.png``: the eye inside CThead (bone preset, shaded, a 100-degree view), by the default grid
  renderer and by shear-warp factored by pyramids of rays (three here).

The frame times are printed: one frame each on this machine, after a first one that makes the
encodings, normals and textures.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dvr_gl.bench.picks import baseline
from dvr_gl.bench.pictures import head, timed
from dvr_gl.image import side_by_side, write_image
from dvr_gl.renderers import create_renderer
from dvr_gl.scene.resolve import load_scene

REPO = Path(__file__).resolve().parents[4]


def shaded_shearwarp(size: int, data_dir: Path) -> np.ndarray:
    scene, label = head(size, data_dir, "ct-bone-ivory")
    print(f"shear-warp shaded ({label}):")
    with create_renderer(baseline()) as raycast, create_renderer("shearwarp") as shearwarp:
        pictures = [timed(raycast, scene.with_renderer(name=baseline()), f"{baseline()}, shaded"),
                    timed(shearwarp, scene.with_renderer(name="shearwarp"), "shearwarp, shaded by tables"),
                    timed(shearwarp, scene.with_renderer(name="shearwarp", shading=type(scene.renderer.shading)(
                        enabled=False)), "shearwarp, unshaded")]
    return side_by_side(pictures)


def inside_shearwarp(size: int, data_dir: Path) -> np.ndarray:
    scene, label = head(size, data_dir, "ct-bone-ivory")
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.field.bounds)
    centre, span = (lo + hi) / 2.0, hi - lo
    eye = centre + np.array([0.05, -0.1, 0.05]) * span  # inside the skull, looking out at an angle
    target = eye + np.array([0.6, -1.0, 0.45]) * span.max()
    scene = load_scene(None, {**_head_keys(scene), "camera.eye": list(eye), "camera.target": list(target),
                              "camera.fov": 100.0, "camera.up": [0, 0, -1]})
    print(f"eye inside ({label}):")
    with create_renderer(baseline()) as raycast, create_renderer("shearwarp") as shearwarp:
        pictures = [timed(raycast, scene.with_renderer(name=baseline()), baseline()),
                    timed(shearwarp, scene.with_renderer(name="shearwarp"), "shearwarp")]
        print(f"  shear-warp's factorizations: {shearwarp.stats['factorizations']}")
    return side_by_side(pictures)


def _head_keys(scene) -> dict:
    """The scene-file keys of :func:`dvr_gl.bench.pictures.head`'s scene (its data, transfer function, image,
    shading)."""
    source = scene.volume_source
    keys = {"image.width": scene.image.width, "image.height": scene.image.height, "renderer.shading.enabled": True}
    if source.path:
        return {**keys, "volume.path": source.path, "transfer_function.preset": "ct-bone-ivory",
                "transfer_function.rescale_intercept": -1024.0}
    return {**keys, "volume.demo": source.demo, "volume.size": source.size}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--data-dir", default=str(REPO.parent / "shared" / "data"))
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = p.parse_args(argv)
    out = Path(args.out)
    write_image(out / "shearwarp-shaded.png", shaded_shearwarp(args.size, Path(args.data_dir)), overwrite=True)
    write_image(out / "shearwarp-inside.png", inside_shearwarp(args.size, Path(args.data_dir)), overwrite=True)
    print(f"wrote shearwarp-shaded.png and shearwarp-inside.png in {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
