"""``dvr bench gpu`` on llvmpipe at tiny sizes: both files, the device named, every renderer the registry lists
for the bench's kinds of data, a tiny time budget kept by leaving cases out with a note; the ladder's rule."""

import json
import time

import pytest

from dvr_gl.apps.cli import main


def test_bench_gpu_names_the_device_lists_every_renderer_and_keeps_a_tiny_budget(tmp_path, capsys):
    from dvr_gl.bench.gpu import FILES, KINDS
    from dvr_gl.renderers import registry

    # 0.2 s: the first case's warm-up alone (a context, compiled programs) spends it, so later cases are skipped
    assert main(["bench", "gpu", "--volume-size", "16", "--size", "32", "--frames", "1", "--time-budget", "0.2",
                 "--no-peers", "--out", str(tmp_path), "-q"]) == 0
    markdown, record = (tmp_path / FILES[0]).read_text(), json.loads((tmp_path / FILES[1]).read_text())
    device = record["device"]
    assert device["GL_RENDERER"] and device["GL_VERSION"] and device["GL_RENDERER"] in markdown
    listed = [(r["data"], r["renderer"]) for r in record["rows"]]
    expected = {(kind, name) for kind in KINDS
                for name in registry.renderers_with(lambda p: p.data_kinds is None or kind in p.data_kinds)}
    assert sorted(listed) == sorted(expected) and len(listed) == len(expected)
    assert all(f"| {name} |" in markdown for _, name in listed)
    skipped = [r for r in record["rows"] if "time budget was spent" in (r["note"] or "")]
    assert skipped and all(r.get("frame_ms") is None for r in skipped)
    assert not any(r.get("size") == "16^3" for r in record["rows"])  # nothing reached the full size
    assert "time budget was spent" in markdown and not list(tmp_path.glob(".dvr-*"))


def test_bench_gpu_refuses_bad_input_before_writing(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("OUT", raising=False)
    assert main(["bench", "gpu", "--volume-size", "16", "--size", "32"]) == 1
    assert "give --out DIR" in capsys.readouterr().err
    for flags in (["--time-budget", "0"], ["--volume-size", "4"], ["--out", str(tmp_path / "nosuch")]):
        assert main(["bench", "gpu", "--out", str(tmp_path), *flags]) == 1
    (tmp_path / "gpu-bench.json").write_text("{}")
    assert main(["bench", "gpu", "--out", str(tmp_path), "--volume-size", "16", "--size", "32"]) == 1
    assert "--overwrite" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gpu-bench.json"]


@pytest.mark.parametrize("share, reached", [(0.05, 0), (60.0, 2)])
def test_climb_stops_where_the_next_step_would_overrun_its_share(share, reached):
    """Steps of 10, 20 and 40 ms (sleeps: never shorter): at 0.05 s the second step, predicted at 8x the
    first's (80 ms or more), is over the share and left out, saying so; at 60 s every step runs."""
    from dvr_gl.bench.gpu import climb

    def run_step(step):
        time.sleep(step / 100.0)  # 10, 20, 40 ms: the growth measured (2x) is under the 8x assumed
        return {"step": step}

    row, spent = climb([1, 2, 4], share, run_step, str)
    assert row["step"] == [1, 2, 4][reached]
    assert ("shrunk: 2 predicted" in row["note"]) if reached == 0 else row["note"] is None


def test_climb_notes_a_failure_and_keeps_the_last_step():
    from dvr_gl.bench.gpu import climb

    def run_step(step):
        if step == 2:
            raise RuntimeError("out of memory\nmore")
        return {"step": step}

    row, _ = climb([1, 2, 4], 60.0, run_step, lambda s: f"size {s}")
    assert row["step"] == 1 and row["note"] == "failed at size 2: out of memory"


def test_climb_charges_the_making_of_data_not_made_yet():
    """A next step whose data would take 100 s to make is left out of a 60 s share, however fast the renderer."""
    from dvr_gl.bench.gpu import climb

    row, _ = climb([1, 2], 60.0, lambda step: {"step": step, "making_s": 0.0}, str, making=lambda step: 100.0)
    assert row["step"] == 1 and row["note"].startswith("shrunk: 2 predicted 100.0 s")


def test_the_peers_scene_is_one_of_dvr_bench_peers():
    from dvr_gl.bench import gpu, peers

    assert peers.SCENES[gpu.PEER_SCENE] == (gpu.PEER_DEMO, gpu.PEER_MODE)
    assert set(gpu.PEERS) <= set(peers.PEERS)


def test_climb_stops_a_step_that_runs_past_its_share():
    """The second step is predicted to fit (8 x 10 ms) but takes 5 s: the timer stops it at the 0.3 s share."""
    from dvr_gl.bench.gpu import climb

    def run_step(step):
        time.sleep(0.01 if step == 1 else 5.0)
        return {"step": step}

    start = time.perf_counter()
    row, _ = climb([1, 2, 4], 0.3, run_step, str)
    assert time.perf_counter() - start < 2.0
    assert row["step"] == 1 and row["note"].startswith("stopped: 2 ran past the")
