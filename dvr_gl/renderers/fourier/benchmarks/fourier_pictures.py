"""Pictures of Fourier rendering's accuracy for the docs (docs/images/fourier-study.png).

    python dvr_gl/renderers/fourier/benchmarks/fourier_pictures.py [--size 160] [--data-dir ../shared/data]
        [--out docs/images]

Each row, left to right: reference-converged, ``fourier`` at its defaults, ``fourier`` with a cheaper
setting, then each one's absolute error (summed over RGBA, times the gain printed) in grey.

* Row 1, the CThead X-ray (pre-classified, the CT bone preset): the cheaper setting is the cubic
  B-spline slice at the pixels' Nyquist limit (``slice_bandwidth = 0``): its replicas of the bone and
  the frequencies it drops ring beside the skull.
* Row 2, the bucky ball's average: the cheaper setting is the trilinear slice with padding 1.25: the
  replicas (ghosting) of the data, which reaches its faces.

The timings printed are one frame each on this machine.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[4]  # the repository

from dvr_gl.bench.datasets import shared_scenes  # noqa: E402
from dvr_gl.image import side_by_side, write_image  # noqa: E402
from dvr_gl.reference.converged import ConvergedReference  # noqa: E402
from dvr_gl.renderers import create_renderer  # noqa: E402
from dvr_gl.scene.resolve import load_scene  # noqa: E402

ROWS = [("CThead", "xray", {"renderer.slice_interpolation": "cubic_bspline", "renderer.slice_bandwidth": 0.0}, 10.0),
        ("bucky", "average", {"renderer.slice_interpolation": "trilinear", "renderer.padding": 1.25}, 50.0)]


def row(name: str, overrides: dict, mode: str, cheaper: dict, gain: float, size: int) -> list[np.ndarray]:
    scene = load_scene(None, {**overrides, "renderer.name": "fourier", "renderer.compositing": mode,
                              "renderer.classification": "pre", "renderer.shading.enabled": False,
                              "camera.projection": "orthographic", "image.width": size, "image.height": size})
    t = time.perf_counter()
    truth = ConvergedReference(scene.with_renderer(converged_tolerance=1e-4)).render_float64()
    print(f"{name} {mode} reference-converged: {time.perf_counter() - t:.1f} s", flush=True)
    pictures, errors = [truth.astype(np.float32)], []
    with create_renderer("fourier") as fourier:
        for label, variant in (("defaults", scene), ("cheaper", scene.with_renderer(**{k.split(".", 1)[1]: v
                                                                                    for k, v in cheaper.items()}))):
            fourier.render(variant)  # the spectrum, once
            t = time.perf_counter()
            image = fourier.render(variant)
            print(f"{name} {mode} fourier {label}: {1e3 * (time.perf_counter() - t):.0f} ms a view", flush=True)
            pictures.append(image)
            error = np.abs(image.astype(np.float64) - truth).sum(axis=2) * gain
            grey = np.repeat(np.clip(error, 0.0, 1.0)[..., None], 4, axis=2).astype(np.float32)
            grey[..., 3] = 1.0
            errors.append(grey)
            rms = float(np.sqrt(np.mean((image - truth) ** 2)) / truth.max())
            print(f"  RMS over the image's maximum {rms:.2e}; error shown times {gain:g}", flush=True)
    return pictures + errors


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=160)
    parser.add_argument("--data-dir", default=str(REPO.parent / "shared" / "data"))
    parser.add_argument("--out", default=str(REPO / "docs" / "images"))
    args = parser.parse_args(argv)
    rows = []
    for name, mode, cheaper, gain in ROWS:
        scenes, notes = shared_scenes(Path(args.data_dir), name)
        if not scenes:
            print("; ".join(notes) or f"{name} not found", file=sys.stderr)
            return 1
        rows.append(side_by_side(row(name, scenes[0][1], mode, cheaper, gain, args.size)))
    write_image(Path(args.out) / "fourier-study.png", side_by_side(rows, axis=0), overwrite=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
