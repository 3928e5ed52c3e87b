"""The sandbox for scenes one did not write (issue 14, item 4): files only inside the roots (after
``..`` and symlinks), no FIFOs or devices, outputs inside the roots, a memory budget and a time limit."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import dvr_gl
from dvr_gl.apps.cli import main
from dvr_gl.sandbox import Sandbox, SandboxError, active, memory_budget, parse_bytes
from dvr_gl.scene.resolve import load_scene
from judges import DISCRETE

SCENE = '[volume]\npath = "{path}"\n[image]\nwidth = 8\nheight = 8\n'


@pytest.fixture
def box(tmp_path):
    """``root/`` holding a small volume, and ``outside/`` beside it holding another."""
    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    for folder in (root, outside):
        np.save(folder / "v.npy", np.linspace(0, 1, 64, dtype=np.float32).reshape(4, 4, 4))
    return root, outside


def _scene(folder, volume_path, name="s.toml"):
    path = folder / name
    path.write_text(SCENE.format(path=volume_path))
    return path


def test_files_inside_the_roots_load(box):
    root, _ = box
    with active(Sandbox((root,))):
        assert load_scene(_scene(root, "v.npy")).field.data.shape == (4, 4, 4)


@pytest.mark.parametrize("how", ["absolute", "dot-dot", "symlink"])
def test_a_volume_outside_the_roots_is_refused(box, how):
    root, outside = box
    if how == "symlink":
        (root / "link.npy").symlink_to(outside / "v.npy")
    volume = {"absolute": outside / "v.npy", "dot-dot": "../outside/v.npy", "symlink": "link.npy"}[how]
    with active(Sandbox((root,))), pytest.raises(SandboxError, match="volume file lies outside the allowed"):
        load_scene(_scene(root, volume))


def test_a_scene_file_outside_the_roots_is_refused(box):
    root, outside = box
    with active(Sandbox((root,))), pytest.raises(SandboxError, match="scene file lies outside"):
        load_scene(_scene(outside, "v.npy"))


@pytest.mark.parametrize("what", ["scene", "volume"])
def test_fifos_are_refused_without_blocking(box, what):
    root, _ = box
    fifo = root / "pipe"
    os.mkfifo(fifo)
    scene = fifo if what == "scene" else _scene(root, "pipe")
    start = time.perf_counter()
    with active(Sandbox((root,))), pytest.raises(SandboxError, match="not a regular file"):
        load_scene(scene)
    assert time.perf_counter() - start < 5  # refused from stat(), never opened (opening would block)


def test_devices_are_refused():
    with pytest.raises(SandboxError, match="not a regular file"):
        load_scene("/dev/zero")


LONG = "a" * 300


@pytest.mark.parametrize("path, fragment", [
    ("ok\x00.nrrd", "volume file's path holds a NUL byte"), (LONG + ".nrrd", r"too long \(305 bytes, over the 255"),
    (LONG + "/v.nrrd", r"too long \(300 bytes"), ("*\x00.nrrd", "NUL byte")])
def test_paths_no_file_can_have_are_one_line(tmp_path, path, fragment):
    """A NUL byte or a name over 255 bytes fails every look-up (ValueError, OSError ENAMETOOLONG, even in
    Path.is_dir): refused where the path enters, a volume's, a scene file's and a transfer function's."""
    with pytest.raises(SandboxError, match=fragment):
        load_scene(None, {"volume.path": path})
    with pytest.raises(SandboxError, match=fragment.replace("volume", "scene")):
        load_scene(tmp_path / path.replace(".nrrd", ".toml"))
    with pytest.raises(SandboxError, match=fragment.replace("volume", "transfer function")):
        load_scene(None, {"volume.demo": "shepp-logan", "transfer_function.file": path})


def test_a_fifo_is_never_replaced_by_an_output(tmp_path, capsys):
    os.mkfifo(tmp_path / "o.png")
    code = main(["render", "--demo", "--size", "8", "--set", "volume.size=8", "--overwrite",
                 "-o", str(tmp_path / "o.png")])
    assert code == 1 and "is not a regular file" in capsys.readouterr().err
    assert (tmp_path / "o.png").is_fifo()


def test_outputs_outside_the_roots_are_refused(box, capsys):
    root, outside = box
    code = main(["render", "--sandbox", str(root), str(_scene(root, "v.npy")), "-o", str(outside / "o.png")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and "o.png: the output file lies outside the allowed folders" in err and "\n" not in err
    assert not (outside / "o.png").exists()
    assert main(["render", "--sandbox", str(root), str(_scene(root, "v.npy")), "-o", str(root / "o.png"),
                 "--quiet"]) == 0
    assert (root / "o.png").exists()


@pytest.fixture
def unbounded_work(monkeypatch):
    """The work estimate (dvr_gl.limits) refuses up front what the measured rates say would run past
    the time limit; faster rates let a slow render start, so that the timer is what stops it."""
    from dvr_gl import limits

    monkeypatch.setattr(limits, "RATES", {unit: 1e6 * rate for unit, rate in limits.RATES.items()})


def test_time_limit_stops_a_slow_render(unbounded_work):
    """The float64 reference at 1/2000 voxel takes seconds (3.3 s measured); the timer stops it at 0.3 s,
    between numpy operations."""
    start = time.perf_counter()
    with pytest.raises(SandboxError, match="time limit of 0.3 s"):
        dvr_gl.render(np.random.default_rng(0).random((24, 24, 24)), size=32, renderer=DISCRETE,
                      sample_distance_voxels=0.0005, sandbox=Sandbox(max_seconds=0.3))
    assert time.perf_counter() - start < 2.0
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)  # the timer is disarmed after


def test_a_nested_time_limit_leaves_the_outer_one_running():
    with pytest.raises(SandboxError, match="time limit of 0.5 s"):
        with active(Sandbox(max_seconds=0.5)):
            with active(Sandbox(max_seconds=100)):
                pass
            assert 0 < signal.getitimer(signal.ITIMER_REAL)[0] <= 0.5
            time.sleep(2)  # interrupted by the outer limit
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)


def test_time_limit_on_the_command_line_is_one_line(tmp_path, capsys, unbounded_work):
    code = main(["render", "--demo", "--set", "volume.size=24", "--size", "32", "--renderer", DISCRETE,
                 "--sample-distance-voxels", "0.0005", "--max-seconds", "0.3", "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and "ran past the time limit of 0.3 s (--max-seconds)" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []  # no output, no temporary file


def test_work_over_the_time_limit_is_refused_before_it_starts(tmp_path, capsys):
    """Without faked rates, the same render is refused at once by the work estimate (at the rate
    measured here it would take longer than the limit), in one line, writing nothing."""
    code = main(["render", "--demo", "--set", "volume.size=24", "--size", "32", "--renderer", DISCRETE,
                 "--sample-distance-voxels", "0.0005", "--max-seconds", "0.3", "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and f"{DISCRETE} would take" in err and "over the bound of 3e+06" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_cpu_backstop_kills_a_call_the_timer_cannot_interrupt():
    """One C call (``sum`` over a range) holds the interpreter, so the timer's handler never runs; the
    CPU-time limit (1 s per core plus the grace, here 0) ends the process with SIGXCPU."""
    code = textwrap.dedent("""
        from dvr_gl import sandbox
        sandbox.CPU_GRACE_SECONDS = 0
        with sandbox.active(sandbox.Sandbox(max_seconds=1)):
            sum(range(10**12))
    """)
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", code], timeout=60)
    assert proc.returncode == -signal.SIGXCPU
    assert time.perf_counter() - start < 30


def test_cpu_limit_is_restored_after():
    import resource

    before = resource.getrlimit(resource.RLIMIT_CPU)
    with active(Sandbox(max_seconds=100)):
        assert resource.getrlimit(resource.RLIMIT_CPU)[0] != before[0]
    assert resource.getrlimit(resource.RLIMIT_CPU) == before


def test_memory_budget_follows_the_flag(tmp_path, capsys):
    with active(Sandbox(max_bytes=parse_bytes("3MiB"))):
        assert memory_budget() == 3 << 20
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * 5000 + "\n")
    code = main(["render", str(big), "--max-memory", "4kB", "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err
    assert code == 1 and "over the memory budget of" in err


def test_memory_budget_refuses_a_big_volume(box):
    root, _ = box
    np.save(root / "big.npy", np.zeros((64, 64, 64), np.float32))  # 1 MiB
    with active(Sandbox((root,), max_bytes=64 << 10)), pytest.raises(SandboxError, match="memory budget"):
        load_scene(_scene(root, "big.npy"))


@pytest.mark.parametrize("argv, fragment", [
    (["--max-memory", "banana"], "--max-memory 'banana': give a size"),
    (["--max-memory", "0"], "--max-memory '0'"),
    (["--max-seconds", "0"], "--max-seconds) must be in (0,"),
    (["--max-seconds", "nan"], "--max-seconds) must be in (0,"),
    (["--max-seconds", "inf"], "--max-seconds) must be in (0,"),
    (["--sandbox", "/no/such/folder"], "must be an existing folder"),
    (["--max-seconds", "-1"], "--max-seconds) must be in (0,"),
    (["--max-seconds", "1e400"], "--max-seconds) must be in (0,"),
    (["--max-memory", "1e30"], "from 1 byte to 8 EiB"),
    (["--max-memory", "-5"], "from 1 byte to 8 EiB"),
    (["--max-memory", "8EiB"], "from 1 byte to 8 EiB"),
])
def test_bad_sandbox_flags_are_one_line(tmp_path, capsys, argv, fragment):
    code = main(["render", "--demo", "--size", "8", *argv, "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and fragment in err and "\n" not in err, err


@pytest.mark.parametrize("seconds", ["1e-9", "1e-300"])
def test_a_deadline_passed_before_the_render_starts_is_one_line(tmp_path, capsys, seconds):
    """The timer fires inside setitimer itself (before the body is entered): the same one line, no traceback
    of the timer's private exception."""
    code = main(["render", "--demo", "--size", "8", "--max-seconds", seconds, "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and "ran past the time limit" in err and "\n" not in err, err
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)
    assert list(tmp_path.iterdir()) == []


def test_a_sandbox_root_that_is_a_file_is_one_line(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    code = main(["render", "--demo", "--size", "8", "--sandbox", str(tmp_path / "file"), "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and "must be an existing folder" in err and "\n" not in err, err


def test_a_symlinked_root_confines_to_its_target(box):
    """A root given through a link is the folder it points to: what lies there loads, a link out does not."""
    root, outside = box
    link = root.parent / "link-to-root"
    link.symlink_to(root)
    with active(Sandbox((link,))):
        assert load_scene(_scene(link, "v.npy")).field.data.shape == (4, 4, 4)
        with pytest.raises(SandboxError, match="outside the allowed"):
            load_scene(_scene(link, outside / "v.npy", "t.toml"))


VP = "1\n0\n0.9\n0.1\n0.2\n10\n4 0 0 1 1\n4 0 1 255 1\n8 0 0 0 0 1 1 1 1\n"
OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


@pytest.mark.parametrize("key", ["transfer_function", "geometry"])
@pytest.mark.parametrize("how", ["absolute", "dot-dot", "symlink"])
def test_every_path_a_scene_names_is_confined(box, key, how):
    """A transfer-function file and a mesh named by a scene (absolute, with .., or a link inside the root
    pointing out) are read only inside the roots, as the volume is; the same file inside loads."""
    root, outside = box
    name = {"transfer_function": "tf.vp", "geometry": "m.obj"}[key]
    for folder in (root, outside):
        (folder / name).write_text(VP if key == "transfer_function" else OBJ)
    (root / ("link" + name)).symlink_to(outside / name)
    target = {"absolute": outside / name, "dot-dot": f"../outside/{name}", "symlink": "link" + name}[how]
    table = {"transfer_function": '[transfer_function]\nfile = "{p}"\n',
             "geometry": '[[renderer.geometry]]\npath = "{p}"\n'}[key]  # the grid's default renderer
    scene = root / "s.toml"
    with active(Sandbox((root,))):
        scene.write_text(SCENE.format(path="v.npy") + table.format(p=name))
        load_scene(scene)  # inside: fine
        scene.write_text(SCENE.format(path="v.npy") + table.format(p=target))
        with pytest.raises(SandboxError, match="lies outside the allowed folders"):
            load_scene(scene)


def test_a_transfer_function_flag_outside_the_roots_is_one_line(box, capsys):
    root, outside = box
    (outside / "tf.vp").write_text(VP)
    code = main(["render", str(root / "v.npy"), "--size", "8", "--sandbox", str(root), "--transfer-function",
                 str(outside / "tf.vp"), "-o", str(root / "o.png")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and "transfer function file lies outside the allowed folders" in err and "\n" not in err, err
    assert not (root / "o.png").exists()
