"""Property-based fuzzing of the mesh readers (issue 40): volume meshes (``.vtu`` in every layout,
legacy ``.vtk`` unstructured grids) and surface meshes for ``[[renderer.geometry]]`` (OBJ, PLY, STL).

A mutated file is a user error (DvrError, one line) or a valid mesh (finite points, every index
naming a point, finite values), printing nothing, within the time and memory budgets of
``fuzz_inputs``.  Mutations are byte-level and line-level (``fuzz_inputs``) and structural: the
cells' offsets, connectivity, types and counts changed and the file written again, valid XML or
legacy syntax around damaged meaning.  Hypothesis is derandomized, a few seconds in all.
"""

from __future__ import annotations

import contextlib
import io
import random

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
pytest.importorskip("meshio")
# after importorskip on purpose: hypothesis and meshio are optional (E402)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import mesh_inputs as mi  # noqa: E402
from dvr_gl import geometry  # noqa: E402
from dvr_gl.errors import DvrError  # noqa: E402
from dvr_gl.fields.mesh import TetMesh  # noqa: E402
from dvr_gl.io import load_field  # noqa: E402
from dvr_gl.sandbox import Sandbox, active  # noqa: E402
from fuzz_inputs import BUDGET, TIMEOUT, mutate_bytes, mutate_lines, time_limit  # noqa: E402

FUZZ = settings(max_examples=25, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

VOLUME_SEEDS = {**{f"m-{e}.vtu": (lambda e=e: mi.vtu(e)) for e in ("ascii", "binary", "zlib", "raw", "appended64")},
                **{f"m-{v}-{'bin' if b else 'ascii'}.vtk": (lambda v=v, b=b: mi.legacy(b, v))
                   for v in ("4.2", "5.1") for b in (False, True)}}
SURFACE_SEEDS = {"s.obj": mi.obj, "s-ascii.ply": lambda: mi.ply(False), "s-bin.ply": lambda: mi.ply(True),
                 "s-ascii.stl": lambda: mi.stl(False), "s-bin.stl": lambda: mi.stl(True),
                 "s-ascii.vtk": lambda: mi.polydata(False), "s-bin.vtk": lambda: mi.polydata(True),
                 "s.vtu": lambda: mi.vtu("zlib", points=mi.CORNERS, cells=[(5, t) for t in mi.TRIANGLES.tolist()],
                                         point_values=np.zeros(4), cell_values=np.zeros(4))}
TEXT = ("ascii", ".obj", "s-ascii", "4.2-ascii", "5.1-ascii")


@contextlib.contextmanager
def bounded():
    """The sandbox's budget, the time limit, and nothing printed (a library's line would reach the user)."""
    printed = io.StringIO()
    try:
        with active(Sandbox(max_bytes=BUDGET)), time_limit(TIMEOUT), \
                contextlib.redirect_stderr(printed), contextlib.redirect_stdout(printed):
            yield
    finally:
        assert not printed.getvalue(), f"printed {printed.getvalue()[:200]!r}"


def check_volume_mesh(path) -> str:
    try:
        with bounded():
            mesh = load_field(path)
    except DvrError as exc:
        assert str(exc) and "\n" not in str(exc)
        return "user error"
    assert isinstance(mesh, TetMesh)
    assert np.isfinite(mesh.points).all() and np.isfinite(mesh.values).all()
    assert len(mesh.tets) and mesh.tets.min() >= 0 and mesh.tets.max() < len(mesh.points)
    return "mesh"


def check_surface_mesh(path) -> str:
    geometry._read.cache_clear()  # a mutation may keep the size and the modification time
    try:
        with bounded():
            mesh = geometry.read_mesh(path)
            o = np.tile([0.5, 0.5, 5.0], (9, 1))
            d = np.column_stack([np.linspace(-0.1, 0.1, 9), np.linspace(-0.1, 0.1, 9), -np.ones(9)])
            geometry.first_hits([(mesh, np.ones(3))], o, d)
    except DvrError as exc:
        assert str(exc) and "\n" not in str(exc)
        return "user error"
    t = mesh.triangles
    assert t.ndim == 2 and t.shape[1] == 3 and len(t) and t.min() >= 0 and t.max() < len(mesh.vertices)
    assert np.isfinite(mesh.vertices[np.unique(t)]).all()
    return "mesh"


def structural(rnd: random.Random) -> tuple[bytes, str]:
    """A volume mesh with its cells damaged in meaning, written validly: offsets, connectivity, types
    or arrays changed, in a random layout."""
    conn, ends, types = (a.copy() for a in mi.cell_arrays())
    conn, ends, types = conn.astype(np.int64), ends.astype(np.int64), types.astype(np.int64)
    kind = rnd.choice(["offset", "offsets zero", "index", "type", "drop type", "drop offset", "values"])
    change = {}
    if kind == "offset":
        ends[rnd.randrange(len(ends))] += rnd.choice([-3, -1, 1, 2, 100, -100])
    elif kind == "offsets zero":
        ends[:] = 0
    elif kind == "index":
        conn[rnd.randrange(len(conn))] = rnd.choice([-1, len(mi.POINTS), 2**31, -2**40, rnd.randrange(30)])
    elif kind == "type":
        types[rnd.randrange(len(types))] = rnd.choice([0, 1, 5, 9, 11, 12, 13, 14, 24, 25, 42, 99, 255])
    elif kind == "drop type":
        types = types[:-1]
    elif kind == "drop offset":
        ends = ends[:-1]
    else:
        change = rnd.choice([dict(point_values=mi.POINT_VALUES[:-1]), dict(cell_values=np.ones(7)),
                             dict(point_values=np.full(len(mi.POINTS), np.nan)),
                             dict(points=np.where(np.arange(57).reshape(19, 3) == 7, np.inf, mi.POINTS))])
    offsets_damaged = kind in ("offset", "offsets zero", "drop offset")
    if offsets_damaged or rnd.random() < 0.5:
        encoding = rnd.choice(["ascii", "binary", "zlib", "raw", "appended64"])
        return mi.vtu(encoding, connectivity=conn, offsets=ends, types=np.clip(types, 0, 255), **change), \
            f"vtu {encoding} {kind}"
    # legacy: the cells from the (damaged) connectivity, types or arrays, and sometimes a wrong CELLS size
    starts = np.concatenate([[0], ends[:-1]])
    cells = [(10, conn[s:e].tolist()) for s, e in zip(starts, ends)]
    blob = mi.legacy(rnd.random() < 0.5, rnd.choice(["4.2", "5.1"]), cells=cells, types=types, **change)
    if rnd.random() < 0.3:
        blob = blob.replace(b"CELLS 5 38", f"CELLS 5 {38 + rnd.choice([-1, 1, 7])}".encode())
    return blob, f"legacy {kind}"


@pytest.mark.parametrize("name", list(VOLUME_SEEDS))
def test_volume_mesh_seeds_read(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(VOLUME_SEEDS[name]())
    assert check_volume_mesh(path) == "mesh"


@pytest.mark.parametrize("name", list(SURFACE_SEEDS))
def test_surface_mesh_seeds_read(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(SURFACE_SEEDS[name]())
    assert check_surface_mesh(path) == "mesh"


def _mutated(tmp_path, name, blob, rnd):
    """``blob`` mutated (its lines, half the time for a text format, else its bytes), written as ``name``."""
    blob, _ = mutate_lines(blob, rnd) if any(t in name for t in TEXT) and rnd.random() < 0.5 \
        else mutate_bytes(blob, rnd)
    path = tmp_path / name
    path.write_bytes(blob)
    return path


@FUZZ
@given(name=st.sampled_from(sorted(VOLUME_SEEDS)), rnd=st.randoms(use_true_random=False))
def test_mutated_volume_meshes_are_user_errors_or_meshes(tmp_path, name, rnd):
    check_volume_mesh(_mutated(tmp_path, name, VOLUME_SEEDS[name](), rnd))


@settings(FUZZ, max_examples=40)
@given(rnd=st.randoms(use_true_random=False))
def test_structurally_damaged_volume_meshes_are_user_errors_or_meshes(tmp_path, rnd):
    blob, what = structural(rnd)
    path = tmp_path / ("m.vtu" if what.startswith("vtu") else "m.vtk")
    path.write_bytes(blob)
    check_volume_mesh(path)


@FUZZ
@given(name=st.sampled_from(sorted(SURFACE_SEEDS)), rnd=st.randoms(use_true_random=False))
def test_mutated_surface_meshes_are_user_errors_or_meshes(tmp_path, name, rnd):
    check_surface_mesh(_mutated(tmp_path, name, SURFACE_SEEDS[name](), rnd))
