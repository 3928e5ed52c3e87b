"""Shared fixtures: the shared datasets folder, small scenes, a GL context."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dvr_gl.scene import load_scene

REPO = Path(__file__).resolve().parent.parent
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not (SHARED_DATA / "README.md").is_file():
        pytest.skip(f"shared datasets not found at {SHARED_DATA} (they live beside the repository)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def gl_context():
    from dvr_gl.gl.context import create_context

    ctx = create_context()
    yield ctx
    ctx.release()


def small_scene(overrides: dict | None = None, **kw):
    """A small demo scene (32^3 Shepp-Logan, 32x32 image) with overrides by dotted key."""
    base = {"volume.demo": "shepp-logan", "volume.size": 32, "image.width": 32, "image.height": 32}
    base.update(overrides or {})
    base.update({k.replace("__", "."): v for k, v in kw.items()})
    return load_scene(None, base)


def array_scene(tmp_path: Path, data: np.ndarray, overrides: dict, spacing=(1.0, 1.0, 1.0),
                origin=(0.0, 0.0, 0.0)):
    """A scene over ``data[z, y, x]`` saved as .npy in ``tmp_path``."""
    path = tmp_path / f"vol_{abs(hash(data.tobytes())) % 10**8}.npy"
    np.save(path, data)
    base = {"volume.path": str(path), "volume.spacing": list(spacing), "volume.origin": list(origin)}
    base.update(overrides)
    return load_scene(None, base)
