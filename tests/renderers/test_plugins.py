"""A renderer in another package (tests/plugins/example-renderer) joins dvr-gl without an edit to it.

The package is installed into a folder of its own with pip (its entry point in the group
``dvr_gl.renderers`` is its only link to dvr-gl), and every run below is a fresh process with that
folder on PYTHONPATH: the renderer shows in ``dvr info``, renders with ``dvr render --renderer``,
refuses what it does not declare in one line, appears among the viewer's renderers (keys, panel) and
runs in ``dvr view``, is swept by ``dvr bench tradeoff``, and passes the conformance tests, which
generate its cases from the registry.
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO
from judges import DISCRETE

PLUGIN_SOURCE = REPO / "tests" / "plugins" / "example-renderer"
NAME = "cpu-projection"
SMALL = ["--demo", "--set", "volume.size=16", "--size", "24"]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The example plugin installed with pip into its own folder (not into dvr-gl's environment)."""
    target = tmp_path_factory.mktemp("plugin-site")
    build = tmp_path_factory.mktemp("plugin-build")
    pip = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                          "--no-index", "--target", str(target), str(PLUGIN_SOURCE)],
                         capture_output=True, text=True, cwd=build)
    assert pip.returncode == 0, pip.stderr[-2000:]
    assert list(target.glob("dvr_gl_example_renderer-*.dist-info"))
    return target


def run(site: Path, *args: str, cwd: Path | None = None, env: dict | None = None) -> subprocess.CompletedProcess:
    environment = dict(os.environ, PYTHONPATH=str(site), **(env or {}))
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, cwd=cwd, env=environment,
                          timeout=600)


def dvr(site: Path, *args: str, **kw) -> subprocess.CompletedProcess:
    return run(site, "-m", "dvr_gl.apps.cli", *args, **kw)


def test_not_registered_without_the_package():
    """The control: in this environment (without the folder on the path) the renderer is unknown."""
    from dvr_gl.renderers import registry

    assert NAME not in registry.names()


def test_dvr_info_lists_it(site):
    out = dvr(site, "info")
    assert out.returncode == 0, out.stderr
    assert f"{NAME}: CPU maximum, minimum and average intensity projection" in out.stdout
    assert "compositing: mip, minip, average" in out.stdout


def test_dvr_render_renders_with_it_and_refuses_in_one_line(site, tmp_path):
    image = tmp_path / "mip.exr"
    out = dvr(site, "render", *SMALL, "--renderer", NAME, "--compositing", "mip", "-o", str(image))
    assert out.returncode == 0, out.stderr
    assert f"{NAME}" in out.stdout and image.is_file()
    same = tmp_path / "reference.exr"
    assert dvr(site, "render", *SMALL, "--renderer", DISCRETE, "--compositing", "mip",
               "-o", str(same)).returncode == 0
    from dvr_gl.image import read_image

    ours, judge = read_image(image), read_image(same)
    assert judge[..., :3].max() > 0.01          # the phantom's maximum, faint under the demo's opacities
    assert abs(ours - judge).max() <= 1e-6      # float32 pixels of the same samples (the oracle: 0 measured)
    refused = dvr(site, "render", *SMALL, "--renderer", NAME, "--compositing", "emission_absorption",
                  "-o", str(tmp_path / "ea.png"))  # (the demo alone adapts: an average for this renderer)
    assert refused.returncode == 1
    assert refused.stderr.strip() == (f"dvr render: error: {NAME} does not support renderer.compositing = "
                                      f"'emission_absorption' (it takes mip, minip or average); use raycast, "
                                      f"slicing3d, slicing2d, shearwarp, reference or reference-converged")
    # (the alternatives render every model setting the scene uses: the demo shades, as shear-warp now does)
    assert not (tmp_path / "ea.png").exists()


def test_the_viewer_offers_it(site):
    """Its number key (after the built-in renderers') and the panel's renderer list come from the
    registry, and switching to it is checked (emission-absorption refused, MIP accepted) before
    anything renders."""
    code = ("from dvr_gl.viewer import keys, settings\n"
            "from dvr_gl.scene.resolve import load_scene\n"
            f"print([k for k in keys.key_table() if k[1] == 'renderer_{NAME}'])\n"
            "print(settings.choices('name'))\n"
            "scene = load_scene(None, {'volume.demo': 'shepp-logan', 'volume.size': 16})\n"
            f"print(settings.refusal(scene, name='{NAME}'))\n"
            f"mip = settings.change(scene, compositing='mip')\n"
            f"print(settings.change(mip, name='{NAME}').renderer.name)\n")
    out = run(site, "-c", code)
    assert out.returncode == 0, out.stderr
    key, names, refusal, switched = out.stdout.strip().splitlines()
    assert f"renderer_{NAME}" in key and NAME in names
    assert "does not support renderer.compositing = 'emission_absorption'" in refusal
    assert switched == NAME


def test_dvr_view_runs_it(site, tmp_path):
    """The viewer renders with it in a window (Xvfb): the frame log names it at full quality."""
    from xvfb import xvfb_display

    with xvfb_display() as display:
        log = tmp_path / "frames.jsonl"
        out = dvr(site, "view", "--demo", "--set", "volume.size=16", "--size", "48x48", "--renderer", NAME,
                  "--compositing", "mip", "--no-gui", "--benchmark", "0.3", "--frame-log", str(log),
                  env={"DISPLAY": display})
    assert out.returncode == 0, out.stderr
    frames = [line for line in log.read_text().splitlines() if '"frame"' in line]
    assert frames and all(f'"renderer": "{NAME}"' in f for f in frames)
    assert any('"state": "full"' in f for f in frames) and "interactive:" in out.stdout


def test_dvr_bench_tradeoff_sweeps_it(site, tmp_path):
    prefix = tmp_path / "tradeoff"
    out = dvr(site, "bench", "tradeoff", "--demo", "shepp-logan", "--volume-size", "16", "--size", "16",
              "--repeat", "1", "--renderers", NAME, "--set", "renderer.compositing=mip", "--output", str(prefix),
              "--no-plot")
    assert out.returncode == 0, out.stderr
    rows = list(csv.DictReader(open(f"{prefix}.csv")))
    assert {r["renderer"] for r in rows} == {NAME}
    assert {r["family"] for r in rows} == {"post, linear", "nearest", "LUT size"}
    assert all(float(r["rms"]) < 0.05 for r in rows if r["family"] == "post, linear" and r["setting"] == "0.125")


def test_conformance_tests_cover_it(site):
    """The conformance tests generate the plugin's cases (modes it declares x closed forms x views, and
    its oracle) from the registry, and it passes them."""
    # One run, verbose: each case's id and outcome on its own line (a collect-only run first cost a second
    # process and collection for the same list).
    passed = run(site, "-m", "pytest", "-v", "-p", "no:cacheprovider",
                 str(REPO / "tests" / "renderers" / "test_conformance.py"), "-k", NAME, cwd=REPO)
    ids = [line for line in passed.stdout.splitlines() if "test_conformance.py::" in line and NAME in line]
    assert len(ids) >= 20, passed.stdout[-2000:]
    assert any("ramp-mip-orthographic" in i for i in ids) and any("against_its_oracle" in i for i in ids)
    assert passed.returncode == 0, passed.stdout[-3000:]
    assert all(" PASSED" in i for i in ids), [i for i in ids if " PASSED" not in i]
    assert f"{len(ids)} passed" in passed.stdout
