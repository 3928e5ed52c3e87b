"""``dvr info FILE``: the facts of a data file, exact where they can be (the value range), and a suggested
command line that runs as printed."""

import shlex

import numpy as np
import pytest

from conftest import run_cli
from judges import DISCRETE

DATA = (np.arange(6 * 5 * 4, dtype=np.int16).reshape(4, 5, 6) * 7 - 300)  # [z, y, x]: -300 .. 533


run = run_cli


def test_grid_facts(tmp_path, capsys):
    np.save(tmp_path / "v.npy", DATA)
    code, out, err = run(capsys, "info", tmp_path / "v.npy")
    assert code == 0, err
    lines = out.splitlines()
    assert "value range: -300 .. 533" in lines
    assert "dims: 6 x 5 x 4 (x, y, z) = 120 samples" in lines and "type: int16" in lines
    assert any(line.startswith("orientation: LPS (identity") for line in lines)
    bars = [line for line in lines if " .. " in line and line.endswith("%")]
    assert len(bars) == 8  # an even ramp: 15 samples in each bin, 12.5%
    assert all(line.endswith("12.5%") for line in bars)


def test_suggested_command_runs_as_printed(tmp_path, capsys):
    np.save(tmp_path / "v.npy", DATA)
    _, out, _ = run(capsys, "info", tmp_path / "v.npy")
    command = next(line.strip() for line in out.splitlines() if line.strip().startswith("dvr render"))
    argv = shlex.split(command)[1:]
    argv[argv.index("out.png")] = str(tmp_path / "out.png")
    # the samples above the minimum (-300) span -293 .. 533: their 2nd and 99.8th percentiles, rounded
    # (-276.48 and 531.3)
    assert "transfer_function.points=[[-276, 0, 0, 0, 0], [531, 1, 1, 1, 0.05]]" in command
    code, _, err = run(capsys, *argv, "--size", "16", "--renderer", DISCRETE)
    assert code == 0, err
    assert (tmp_path / "out.png").is_file()


def test_ct_in_hounsfield_units_suggests_a_ct_preset(tmp_path, capsys):
    np.save(tmp_path / "ct.npy", (DATA * 3 - 100).astype(np.int16))  # -1000 .. 1499
    _, out, _ = run(capsys, "info", tmp_path / "ct.npy")
    assert "value range: -1000 .. 1499" in out and "--transfer-function CT-Bone" in out


def test_oblique_orientation_is_named(tmp_path, capsys):
    pytest.importorskip("nrrd")
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    header = (f"NRRD0004\ntype: int16\ndimension: 3\nsizes: 6 5 4\nendian: little\nencoding: raw\n"
              f"space: left-posterior-superior\nspace directions: ({c},{s},0) ({-s},{c},0) (0,0,2)\n"
              f"space origin: (1,2,3)\n\n")
    (tmp_path / "v.nrrd").write_bytes(header.encode() + DATA.astype("<i2").tobytes())
    _, out, _ = run(capsys, "info", tmp_path / "v.nrrd")
    assert "orientation: lpS (oblique;" in out and "origin: (1, 2, 3)" in out
    assert f"direction:  [{c:+.6f} {-s:+.6f} +0.000000]" in out


def test_float_values_and_a_constant_volume(tmp_path, capsys):
    np.save(tmp_path / "f.npy", np.full((2, 2, 2), 0.25, np.float32))
    _, out, _ = run(capsys, "info", tmp_path / "f.npy")
    assert "value range: 0.25 .. 0.25" in out and "histogram: every sample is 0.25" in out


def test_mesh_facts(shared_data, capsys):
    pytest.importorskip("meshio")
    code, out, err = run(capsys, "info", shared_data / "unstructured/tetraMesh.vtk")
    assert code == 0, err
    assert "mesh, 55 points, 160 tetrahedra" in out and "value range: " in out and "bounds: (" in out


def test_bad_file_is_one_line(tmp_path, capsys):
    (tmp_path / "v.nrrd").write_text("not nrrd")
    code, _, err = run(capsys, "info", tmp_path / "v.nrrd")
    assert code == 1 and len(err.strip().splitlines()) == 1 and "not an NRRD file" in err
