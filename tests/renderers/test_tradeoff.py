"""dvr bench tradeoff: the sweep, the Pareto front, the files it writes, and the registration rule."""

import csv
import json

import numpy as np
import pytest

from conftest import array_scene
from dvr_gl.apps.cli import main
from dvr_gl.bench import plot, tradeoff
from dvr_gl.image import read_image
from dvr_gl.renderers import registry
from dvr_gl.scene import sweeps
from dvr_gl.scene.resolve import load_scene
from judges import renderers

# The renderers these tests sweep, chosen by what they declare: the one that turns a tolerance into
# its settings (it prints --tolerance; its samples get denser down a family), a GL grid renderer that
# does not scatter, one that samples fixed planes (no sample distance: a short sweep), and the one
# that takes particles.
TOLERANT = renderers("tolerance")[0]
UNLIT = next(n for n in renderers(kind="grid", gl=True) if registry.plugin(n).declared("scattering") is None)
FIXED = [n for n in renderers(kind="grid", gl=True) if registry.plugin(n).fixed_planes][-1]
SPLATS = next(n for n, p in registry.plugins().items() if p.data_kinds and "particles" in p.data_kinds)

SMALL = {"volume.demo": "shepp-logan", "volume.size": 24, "image.width": 24, "image.height": 24}


def test_every_renderer_declares_a_sweep():
    """Every registered renderer but the references (the judges) declares its trade-off families in
    its plugin, and the bench sweeps exactly those; each family varies a setting the renderer reads."""
    swept = tradeoff.sweeps()
    assert set(swept) == {name for name, p in registry.plugins().items() if not p.reference}
    for name, families in swept.items():
        declared = set(registry.plugin(name).setting_names)
        for family in families:
            assert isinstance(family, sweeps.Family)
            assert family.key.removeprefix("renderer.").split(".")[0] in declared, (name, family.label)


def test_pareto_front():
    rows = [{"ms": 1.0, "rms": 0.1}, {"ms": 2.0, "rms": 0.2}, {"ms": 3.0, "rms": 0.05}, {"ms": 3.0, "rms": 0.01},
            {"ms": 5.0, "rms": 0.01}, {"ms": 6.0, "rms": 0.001}]
    front = tradeoff.mark_pareto(rows)
    assert [(r["ms"], r["rms"]) for r in front] == [(1.0, 0.1), (3.0, 0.01), (6.0, 0.001)]
    assert tradeoff.cheapest_meeting(rows, 0.02) == {"ms": 3.0, "rms": 0.01, "pareto": "*"}
    assert tradeoff.cheapest_meeting(rows, 1e-4) is None


def test_variant_converts_voxels_and_keeps_the_volume(tmp_path):
    scene = array_scene(tmp_path, np.zeros((4, 4, 4), np.float32), {}, spacing=(0.5, 0.5, 2.0))
    family = sweeps.PREINTEGRATED
    name = next(n for n in renderers("sample_distance_voxels", gl=True) if family in registry.plugin(n).sweeps)
    v = tradeoff.variant(scene, name, family, 2.0)
    assert v.renderer.name == name and v.renderer.classification == "preintegrated"
    assert v.renderer.sample_distance == pytest.approx(1.0)   # 2 voxels of the smallest spacing
    assert v.volume is scene.volume                           # no reload, no re-upload


def test_light_volume_family_only_where_the_scene_scatters(monkeypatch):
    """The light volume's family varies a key of [renderer.scattering] and sweeps only a scene that
    scatters; its error falls with the resolution (on the renderer that sweeps it; the others refuse).
    Of the renderer that sweeps it only this family is measured here (its other families, asserted
    nothing about here, took 15 of 28 s; test_sweep_measures_every_renderer measures them); the
    renderer without scattering is asked for all of its families, and refuses each."""
    lit = load_scene(None, {**SMALL, "volume.size": 16, "image.width": 16, "image.height": 16,
                            "renderer.shading.enabled": False, "renderer.scattering.enabled": True})
    lighter = next(n for n, p in registry.plugins().items() if sweeps.LIGHT_VOLUME in p.sweeps)
    v = tradeoff.variant(lit, lighter, sweeps.LIGHT_VOLUME, 32)
    assert v.renderer.scattering.method == "light_volume" and v.renderer.scattering.light_volume_size == 32
    assert v.renderer.scattering.lights == lit.renderer.scattering.lights
    assert sweeps.LIGHT_VOLUME.applies_to_scene(lit)
    assert not sweeps.LIGHT_VOLUME.applies_to_scene(load_scene(None, SMALL))
    every = tradeoff.cases
    monkeypatch.setattr(tradeoff, "cases", lambda *args: (c for c in every(*args)
                                                          if c[0] != lighter or c[1] is sweeps.LIGHT_VOLUME))
    rows, notes = tradeoff.run(lit, repeat=1, renderers=[lighter, UNLIT])
    assert {r["family"] for r in rows} == {"light volume"}
    curve = [r["rms"] for r in rows if r["family"] == "light volume"]
    assert len(curve) == len(sweeps.LIGHT_VOLUME.values) and curve[0] > curve[2]
    assert not any(r["renderer"] == UNLIT for r in rows)
    assert any(UNLIT in n and "scattering" in n for n in notes)


def test_sweep_measures_every_renderer():
    """Every swept renderer renders; errors are finite and fall as the ray caster's samples get
    denser (4 voxels to 1/8: measured RMS 3.6e-2 to 3.4e-4 here, a factor 100; asserted monotone and
    at least 10x), and a renderer's refusals become notes, not rows."""
    scene = load_scene(None, SMALL)
    rows, notes = tradeoff.run(scene, repeat=1)
    # those that render a grid in perspective
    assert {r["renderer"] for r in rows} == set(tradeoff.sweeps(kind="grid", projection="perspective"))
    for r in rows:
        assert np.isfinite(r["rms"]) and r["ms"] > 0 and r["max"] >= r["rms"] >= 0
        assert r["flip"] is None or 0.0 <= r["flip"] <= 1.0
    curve = [r["rms"] for r in rows if r["renderer"] == TOLERANT and r["family"] == "post, linear"]
    assert all(a > b for a, b in zip(curve, curve[1:])) and curve[0] > 10 * curve[-1]
    assert any(r["pareto"] for r in rows)
    without_pre = [n for n in tradeoff.sweeps(kind="grid", projection="perspective")
                   if "pre" not in registry.plugin(n).choices("classification")]
    assert without_pre
    for name in without_pre:
        assert any(n.startswith(f"{name}: refused classification pre") for n in notes)
        assert not any(r["renderer"] == name and r["setting"] == "pre" for r in rows)


def test_cli_writes_csv_json_plot_and_refuses_to_overwrite(tmp_path, capsys):
    prefix = tmp_path / "to"
    args = ["bench", "tradeoff", "--demo", "shepp-logan", "--volume-size", "20", "--size", "16", "--repeat", "1",
            "--renderers", f"{TOLERANT},{FIXED}", "--set", "renderer.shading.enabled=false", "--output", str(prefix)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "--tolerance E" in out and "front" in out
    with open(f"{prefix}.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    data = json.loads((tmp_path / "to.json").read_text())
    assert len(rows) == len(data["rows"]) > 20
    assert {r["renderer"] for r in rows} == {TOLERANT, FIXED}
    assert float(rows[0]["rms"]) == pytest.approx(data["rows"][0]["rms"])
    assert data["meta"]["scenes"]["shepp-logan"]["tolerance"]
    if plot.have_matplotlib():
        picture = read_image(tmp_path / "to.png")
        assert picture.shape[0] > 200 and picture[..., :3].std() > 0.05
    before = (tmp_path / "to.csv").read_bytes()
    assert main(args) == 1                                   # exists: refused before measuring anything
    assert "--overwrite" in capsys.readouterr().err
    assert (tmp_path / "to.csv").read_bytes() == before


def test_cli_bad_input_is_one_line(tmp_path, capsys):
    assert main(["bench", "tradeoff", "--output", str(tmp_path / "x")]) == 1
    assert "give one of SCENE.toml, --demo NAME or --shared" in capsys.readouterr().err
    assert main(["bench", "tradeoff", "--demo", "shepp-logan", "--renderers", "splat",
                 "--output", str(tmp_path / "x")]) == 1
    err = capsys.readouterr().err
    assert "no sweep for splat" in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_particles_sweep_the_families_made_for_them(tmp_path, capsys):
    """A particle set: only the renderers and families that take particles (splatting's slab width with
    the particles' own kernel, m4), and the ray caster's --tolerance is said not to apply."""
    assert {name: [f.fixed for f in fams] for name, fams in tradeoff.sweeps(kind="particles").items()} == {
        SPLATS: [(("renderer.filter", "m4"),)]}
    assert all(f.fixed != (("renderer.filter", "m4"),) for f in tradeoff.sweeps(kind="grid")[SPLATS])
    prefix = tmp_path / "sph"
    args = ["bench", "tradeoff", "--demo", "plummer", "--volume-size", "8", "--size", "16", "--repeat", "1",
            "--no-plot", "--output", str(prefix)]
    assert main(args) == 0
    with open(f"{prefix}.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["renderer"], r["setting"]) for r in rows] == [(SPLATS, w) for w in ("2", "1", "0.5", "0.25")]
    assert all(np.isfinite(float(r["rms"])) for r in rows)
    assert "--tolerance not checked" in capsys.readouterr().out


def test_nothing_measured_is_an_error_and_writes_nothing(tmp_path, capsys):
    """Every renderer asked for refuses the scene (the ray caster renders no particles): one line, exit 1,
    no files."""
    prefix = tmp_path / "none"
    args = ["bench", "tradeoff", "--demo", "plummer", "--volume-size", "8", "--size", "16", "--repeat", "1",
            "--renderers", TOLERANT, "--no-plot", "--output", str(prefix)]
    assert main(args) == 1
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert "no renderer measured" in err and "\n" not in err
    assert f"no sweep for particles data in perspective views: {TOLERANT}" in captured.out
    assert not list(tmp_path.iterdir())
