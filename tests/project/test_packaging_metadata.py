"""What a user sees of the package: its licence and metadata, ``python -m dvr_gl``, the help texts,
shell completion, and scene files written through tomli-w."""

import dataclasses
import subprocess
import sys
import tomllib

import numpy as np
import pytest

from conftest import REPO
from dvr_gl.apps.cli import main
from dvr_gl.camera import Camera
from dvr_gl.renderers import registry
from dvr_gl.scene.resolve import load_scene
from dvr_gl.toml_writer import dumps

PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())


def test_licence_and_metadata():
    project = PYPROJECT["project"]
    assert project["license"] == "BSD-3-Clause"
    assert project["license-files"] == ["LICENSE"]
    licence = (REPO / "LICENSE").read_text()
    assert licence.startswith("BSD 3-Clause License\n\nCopyright (c) 2026, the dvr-gl developers")
    assert project["authors"] and project["keywords"]
    # an SPDX licence expression replaces the licence classifiers (setuptools refuses both)
    assert not [c for c in project["classifiers"] if c.startswith("License ::")]
    assert "Typing :: Typed" in project["classifiers"]
    assert any(dep.startswith("tomli-w") for dep in project["dependencies"])
    assert "urls" not in project  # no public repository yet: no invented addresses


def test_py_typed_ships_as_package_data():
    assert (REPO / "dvr_gl" / "py.typed").is_file()
    assert "py.typed" in PYPROJECT["tool"]["setuptools"]["package-data"]["dvr_gl"]


def test_changelog_has_the_release_and_unreleased():
    text = (REPO / "CHANGELOG.md").read_text()
    assert "## Unreleased" in text
    assert f"## {PYPROJECT['project']['version']} - " in text


def test_python_dash_m_dvr_gl_is_dvr():
    proc = subprocess.run([sys.executable, "-m", "dvr_gl", "--version"], capture_output=True, text=True,
                          cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"dvr-gl {PYPROJECT['project']['version']}"
    proc = subprocess.run([sys.executable, "-m", "dvr_gl", "render"], capture_output=True, text=True, cwd=REPO)
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_render_help_names_every_renderer(capsys):
    with pytest.raises(SystemExit):
        main(["render", "--help"])
    out = capsys.readouterr().out
    epilog = out[out.index("renderers (--renderer NAME"):]
    for name in registry.plugins():
        assert f"\n  {name} " in epilog, name


def test_bench_help_keeps_one_bench_a_line(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    out = capsys.readouterr().out
    from dvr_gl.renderers.bench_command import commands

    # the renderers' own benches, read from the registry, one a line among the subcommands
    declared = [c.name for p in registry.plugins().values() if p.bench for c in commands(p.bench)]
    assert declared
    for bench in declared:
        assert f"\n    {bench} " in out, bench
    for bench in ("tradeoff", "scattering"):  # the benches across renderers, in the description
        assert f"\n  dvr bench {bench} " in out, bench


@pytest.mark.parametrize("shell", ["bash", "zsh", "tcsh"])
def test_completion_script_names_the_subcommands(capsys, shell):
    pytest.importorskip("shtab", reason="shell completion needs the completion extra (shtab)")
    assert main(["completion", shell]) == 0
    script = capsys.readouterr().out
    for command in ("render", "view", "info", "bench", "completion", "pyramid"):
        assert command in script
    if shell == "bash":
        assert "_shtab_dvr_subparsers=(render view info bench completion pyramid)" in script
        assert "--transfer-function" in script  # the subcommands' flags too


def test_completion_without_shtab_is_one_line(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "shtab", None)  # import shtab now raises ImportError
    assert main(["completion", "bash"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install -e '.[completion]'" in err[0]


def test_toml_writer_makes_numpy_values_plain():
    data = {"t": {"f64": np.float64(221.3), "f32": np.float32(0.1), "i": np.int64(3), "b": np.bool_(True),
                  "a": np.arange(3), "m": np.eye(2, dtype=np.float32), "tuple": (np.float64(1.5), 2)}}
    back = tomllib.loads(dumps(data, header="a header\nof two lines"))
    assert back == {"t": {"f64": 221.3, "f32": float(np.float32(0.1)), "i": 3, "b": True, "a": [0, 1, 2],
                          "m": [[1.0, 0.0], [0.0, 1.0]], "tuple": [1.5, 2]}}
    assert back["t"]["f32"] == np.float32(0.1)  # the float32 value itself, not the nearest float64 to 0.1


def test_saved_scene_with_numpy_camera_loads(tmp_path):
    """A camera orbited with numpy numbers (as the viewer and the API's orbits make) was written as
    ``np.float64(221.3)`` or refused (float32), so the saved scene did not load; it now round-trips."""
    np.save(tmp_path / "v.npy", np.linspace(0.0, 221.3, 512, dtype=np.float32).reshape(8, 8, 8))
    scene = load_scene(None, {"volume.path": str(tmp_path / "v.npy"), "image.width": 8, "image.height": 8})
    camera = Camera.from_orbit(np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 1.0]), np.float64(221.3),
                               np.float32(12.5), np.float64(40.0))
    scene = dataclasses.replace(scene, camera=camera)
    saved = tmp_path / "saved.toml"
    saved.write_text(scene.to_toml(relative_to=tmp_path))
    back = load_scene(saved)
    assert back.camera.to_dict()["azimuth"] == 221.3
    np.testing.assert_array_equal(back.camera.eye, scene.camera.eye)
    np.testing.assert_array_equal(back.transfer_function.points, scene.transfer_function.points)


def test_gallery_page_is_current_and_its_pictures_exist():
    """docs/gallery.md is what benchmarks/gallery.py writes (the commands shown are the ones run), and
    every picture it shows is in docs/images, small enough for the repository (under 300 kB each)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("gallery", REPO / "benchmarks" / "gallery.py")
    gallery = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gallery)
    assert (REPO / "docs" / "gallery.md").read_text(encoding="utf-8") == gallery.markdown(), \
        "run python benchmarks/gallery.py"
    for name, *_ in gallery.PICTURES:
        picture = REPO / "docs" / "images" / f"gallery-{name}.png"
        assert picture.is_file() and picture.stat().st_size < 300_000, picture


def test_install_hints_come_from_one_helper():
    """Every message that says how to install an optional extra says it through
    dvr_gl.errors.install_hint: from a checkout (``pip install -e '.[extra]'``) or a package index."""
    import re
    from pathlib import Path

    import dvr_gl
    from dvr_gl.errors import install_hint

    assert install_hint("plot") == "pip install -e '.[plot]' in the dvr-gl checkout (or pip install 'dvr-gl[plot]')"
    root = Path(dvr_gl.__file__).parent
    sources = [p for p in root.rglob("*.py") if p.name != "errors.py" and "tests" not in p.parts]
    spelled = [f"{p.relative_to(root)}:{n}" for p in sources
               for n, line in enumerate(p.read_text().splitlines(), 1)
               if re.search(r"pip install '?dvr-gl\[", line)]
    assert not spelled, f"spell install hints with dvr_gl.errors.install_hint: {spelled}"
