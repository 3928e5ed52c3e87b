"""What the docs' picture scripts share (benchmarks/docs_pictures.py and the renderers' own picture scripts):
a frame timed after a first one, and CThead as the pictures show it."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..scene.resolve import load_scene


def timed(renderer, scene, label: str) -> np.ndarray:
    """One frame, printed with its time, after a first that makes the encodings, normals and textures."""
    renderer.render(scene)
    start = time.perf_counter()
    image = renderer.render(scene)
    print(f"  {label}: {time.perf_counter() - start:.2f} s")
    return image


def head(size: int, data_dir: Path, preset: str):
    """CThead with a CT preset (HU = data - 1024), shaded, from the shared data; else the Marschner-Lobb
    demo.  ``(scene, label)``."""
    path = data_dir / "regular" / "cthead.nhdr"
    if path.exists():
        return load_scene(None, {"volume.path": str(path), "transfer_function.preset": preset,
                                 "transfer_function.rescale_intercept": -1024.0, "camera.up": [0, 0, -1],
                                 "image.width": size, "image.height": size, "renderer.shading.enabled": True}), "CThead"
    return load_scene(None, {"volume.demo": "marschner-lobb", "volume.size": 64, "image.width": size,
                             "image.height": size, "renderer.shading.enabled": True}), "Marschner-Lobb 64^3"
