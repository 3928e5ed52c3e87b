"""Property-based fuzzing of the particle readers (issue 40): CSV, ``.npz`` and HDF5 particle files,
byte-mutated (``fuzz_inputs.mutate``) and built from random columns (unequal lengths, NaN and Inf,
huge coordinates, missing columns, wrong dtypes and shapes) and, for HDF5, random links (soft, dangling,
looping, external, virtual datasets, external storage).  Each is a user error (DvrError, one line) or a
valid particle set, printing nothing (on the file descriptors too: no HDF5-DIAG stack), within the
time and memory budget of ``fuzz_inputs``; under ``--sandbox`` nothing of the file outside the root is
ever read (its particles are marked).  Derandomized; a few seconds in all.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
# the imports below come after importorskip on purpose: hypothesis is optional (E402)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from dvr_gl.errors import DvrError  # noqa: E402
from dvr_gl.io import load_field  # noqa: E402
from dvr_gl.sandbox import Sandbox, active  # noqa: E402
from fuzz_inputs import BUDGET, TIMEOUT, mutate, seeds, time_limit, write_case  # noqa: E402

SEEDS = [s for s in seeds() if s.reader in ("csv", "npz", "hdf5")]
FUZZ = settings(max_examples=30, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
MARK = 4242.0  # the outside file's particles all sit here: a result holding it read outside the root
NAMES = ["x", "y", "z", "h", "m", "rho", "u", "positions", "hsml", "mass", "density", "X"]
NUMBERS = st.sampled_from([0.0, 1.0, -1.0, 0.5, 2.0, 1e-300, 1e17, -1e17, 1e300, np.nan, np.inf, -np.inf, 3.0])


def check_particles(path, capfd, roots=()) -> str:
    """``user error`` or ``particles``; any other exception (or a hang) propagates."""
    printed = io.StringIO()
    try:
        with active(Sandbox(roots=roots, max_bytes=BUDGET)), time_limit(TIMEOUT), \
                contextlib.redirect_stderr(printed), contextlib.redirect_stdout(printed):
            p = load_field(path)
    except DvrError as exc:
        assert str(exc) and "\n" not in str(exc)
        return "user error"
    finally:
        out, err = capfd.readouterr()
        assert not printed.getvalue() and not out and not err, (printed.getvalue() + out + err)[:300]
    assert p.kind == "particles" and len(p) > 0
    assert np.isfinite(p.positions).all() and np.isfinite(p.values).all()
    assert (p.smoothing_lengths > 0).all() and (p.densities > 0).all() and (p.masses >= 0).all()
    assert not (p.positions == MARK).any(), "read the file outside the sandbox"
    return "particles"


@pytest.mark.parametrize("seed", SEEDS, ids=[s.reader for s in SEEDS])
@FUZZ
@given(rnd=st.randoms(use_true_random=False))
def test_mutated_particle_files(tmp_path, capfd, seed, rnd):
    files, _ = mutate(seed, rnd)
    check_particles(write_case(tmp_path, seed, files), capfd)


def _column(draw, n: int):
    """A column of about ``n`` rows: a number a row mostly, sometimes another length, shape or dtype."""
    kind = draw(st.sampled_from(["floats"] * 6 + ["ints", "short", "long", "2d", "bool", "complex", "text",
                                                     "scalar", "empty"]))
    values = np.array(draw(st.lists(NUMBERS, min_size=n, max_size=n)), dtype=np.float64)
    return {"floats": values, "ints": np.arange(n, dtype=np.int32) + 1, "short": values[:-1], "long":
            np.r_[values, 1.0], "2d": np.tile(values[:, None], 3), "bool": values > 0,
            "complex": values.astype(np.complex128), "text": np.array(["a"] * n), "scalar": np.float64(1.0),
            "empty": np.zeros(0)}[kind]


@FUZZ
@given(data=st.data())
def test_random_npz_and_csv_tables(tmp_path, capfd, data):
    """Tables of random columns: names (aliases, a case clash), lengths, dtypes, shapes, bad numbers."""
    n = data.draw(st.integers(1, 5))
    names = data.draw(st.lists(st.sampled_from(NAMES), min_size=1, max_size=7, unique=True))
    columns = {}
    for name in names:
        column = _column(data.draw, n)
        columns[name] = np.tile(np.asarray(column, float)[:, None], 3) if name == "positions" and \
            np.ndim(column) == 1 and column.dtype.kind == "f" else column
    np.savez(tmp_path / "p.npz", **columns)
    check_particles(tmp_path / "p.npz", capfd)
    rows = [",".join(names)]
    for i in range(n):
        fields = [data.draw(st.sampled_from(["1", "0.5", "-1", "nan", "inf", "1e17", "1e400", "x", "", " 2 ",
                                             '"3"', "1,2"])) for _ in names]
        rows.append(",".join(fields[:data.draw(st.integers(1, len(fields)))]))
    (tmp_path / "p.csv").write_text("\n".join(rows) + "\n")
    check_particles(tmp_path / "p.csv", capfd)


@FUZZ
@given(data=st.data())
def test_random_hdf5_snapshots_under_the_sandbox(tmp_path_factory, capfd, data):
    """Snapshots whose PartType0 datasets are random columns, links (soft, dangling, looping, external
    to a file outside the root), virtual datasets or external raw storage, read under --sandbox: a user
    error or particles, never the outside file's."""
    h5py = pytest.importorskip("h5py")
    base = tmp_path_factory.mktemp("case")
    root, outside = base / "root", base / "outside"
    root.mkdir()
    outside.mkdir()
    n = data.draw(st.integers(1, 4))
    secret = outside / "secret.hdf5"
    with h5py.File(secret, "w") as f:
        gas = f.create_group("PartType0")
        gas["Coordinates"] = np.full((n, 3), MARK)
        gas["SmoothingLength"], gas["Masses"], gas["Density"] = np.ones(n), np.ones(n), np.ones(n)
    np.full((n, 3), MARK).tofile(outside / "raw.bin")
    path = root / "p.hdf5"
    with h5py.File(path, "w") as f:
        gas = f.create_group("PartType0")
        for name in ("Coordinates", "SmoothingLength", "Masses", "Density", "InternalEnergy"):
            how = data.draw(st.sampled_from(["good"] * 4 + ["random", "missing", "soft", "dangling", "loop",
                                                             "external", "virtual", "storage", "group"]))
            good = np.ones((n, 3)) * np.arange(n)[:, None] if name == "Coordinates" else np.ones(n)
            if how == "good":
                gas[name] = good
            elif how == "random":
                column = _column(data.draw, n)
                if column.dtype.kind not in "U":
                    gas[name] = column
            elif how == "soft":
                f[f"data/{name}"] = good
                gas[name] = h5py.SoftLink(f"/data/{name}")
            elif how == "dangling":
                gas[name] = h5py.SoftLink("/nowhere")
            elif how == "loop":
                gas[name] = h5py.SoftLink(f"/PartType0/{name}")
            elif how == "external":
                gas[name] = h5py.ExternalLink(str(secret), f"/PartType0/{name}")
            elif how == "virtual":
                layout = h5py.VirtualLayout(shape=good.shape, dtype="f8")
                layout[:] = h5py.VirtualSource(str(secret), f"PartType0/{name}", shape=good.shape)
                gas.create_virtual_dataset(name, layout)
            elif how == "storage":
                gas.create_dataset(name, shape=good.shape, dtype="<f8",
                                   external=[(str(outside / "raw.bin"), 0, good.size * 8)])
            elif how == "group":
                gas.create_group(name)
        if data.draw(st.booleans()):
            f["Header"] = h5py.ExternalLink(str(secret), "/PartType0")
    check_particles(path, capfd, roots=(root,))
