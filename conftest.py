"""Shared fixtures, written once for every test folder (the renderers' own tests included).

- ``shared_data``: the shared datasets folder (skips without it); ``shared_volumes``: ``load(name)``, a
  dataset's volume, the last one kept.
- ``shared_gl_context``: one headless GL context for the whole run; ``gl_context``: the same, made current
  for a test (a module of GL tests: ``pytestmark = pytest.mark.usefixtures("gl_context")``).  A test of
  context creation or release keeps a context of its own.
- ``xvfb``: one Xvfb display for the whole run (the viewer's tests and the renderers' viewer checks).
- ``converged``: the converged judge; the judges and renderers by trait are in ``tests/judges.py``.
- Helpers: ``small_scene``, ``array_scene``, ``assert_close``, ``run_cli``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dvr_gl.scene.resolve import load_scene

# Every run prints its time per test folder (tests/folder_times.py): .ci/run shows it.
pytest_plugins = ["folder_times"]

REPO = Path(__file__).resolve().parent
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session", autouse=True)
def private_cache_folder(tmp_path_factory):
    """``$XDG_CACHE_HOME`` in a temporary folder for the whole session (children inherit it): dvr-gl's
    cache folder (the key that signs block-ranges sidecars, sidecars of read-only data, bench peers'
    volumes) is never the user's own.  A test may set it again (monkeypatch) for a cache of its own."""
    patch = pytest.MonkeyPatch()
    patch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.mktemp("xdg-cache")))
    yield
    patch.undo()


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not (SHARED_DATA / "README.md").is_file():
        pytest.skip(f"shared datasets not found at {SHARED_DATA} (they live beside the repository)")
    return SHARED_DATA


@pytest.fixture(scope="module")
def shared_volumes(shared_data):
    """``load(name)``: the volume of a file under the shared data folder, the last one kept (one at a
    time: the CT bunny is large)."""
    cache = {}

    def load(name):
        if name not in cache:
            cache.clear()
            cache[name] = load_scene(None, {"volume.path": str(shared_data / name)}).volume
        return cache[name]
    return load


@pytest.fixture(scope="module")
def shared_scene(shared_volumes):
    """``scene(name, overrides)``: the scene ``overrides`` make on the shared dataset ``name``, as
    ``load_scene(None, {"volume.path": ..., **overrides})`` makes it, but on the volume :func:`shared_volumes`
    keeps (a dataset is read once, not once per scene: the CT bunny takes about 11 s to decompress)."""
    from dvr_gl.scene.resolve import apply_overrides, look_up_preset, parse_scene, resolve_scene

    def scene(name, overrides):
        raw = apply_overrides({}, overrides)
        lookup = look_up_preset(raw, Path.cwd())
        return resolve_scene(parse_scene(raw, None, Path.cwd(), lookup), field=shared_volumes(name), lookup=lookup)
    return scene


@pytest.fixture(scope="session")
def xvfb():
    """A running Xvfb's display name (``":N"``), one for the whole run: each test opens its own windows in
    it and closes them (skips, saying why, without Xvfb or libXtst)."""
    from xvfb import xvfb_display

    with xvfb_display() as display:
        yield display


@pytest.fixture(scope="session")
def shared_gl_context():
    from dvr_gl.gl.context import create_context

    ctx = create_context()
    yield ctx
    ctx.release()


@pytest.fixture
def gl_context(shared_gl_context):
    """The session's context, made current for each test: a renderer released by an earlier test
    (``release_context``) leaves no context current on the thread, and GL calls then fail
    ("cannot create program")."""
    from dvr_gl.gl.context import make_current

    return make_current(shared_gl_context)


@pytest.fixture(scope="module")
def converged():
    """The float64 judge of "how accurate?", the converged reference (a CPU renderer: nothing to release),
    picked by what it declares (tests/judges.py)."""
    from dvr_gl.renderers import create_renderer
    from judges import CONVERGED

    return create_renderer(CONVERGED)


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


def assert_close(image, reference):
    """The float32 GPU renderers against a float64 same-discretization reference: at most 0.5 % of
    values off by more than 1e-4 (pixels on a silhouette may fall either way), mean error <= 2e-6 over
    the rest (each test module states what it measured)."""
    err = np.abs(np.asarray(image, dtype=np.float64) - reference)
    close = err <= 1e-4
    assert np.mean(~close) <= 0.005, f"{np.mean(~close):.3%} of values off by > 1e-4"
    assert err[close].mean() <= 2e-6, f"mean {err[close].mean():.3g}"


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    """``dvr ARGV`` in this process: ``(exit code, stdout, stderr)``."""
    from dvr_gl.apps.cli import main

    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's own errors (one line, exit 1: dvr_gl/apps/cli.py)
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err
