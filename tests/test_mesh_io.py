"""Reading the shared unstructured grids (``../shared/data/unstructured``): every file, checked against
the counts and ranges its README states; and malformed mesh files refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import SHARED_DATA
from dvr_gl.errors import DvrError
from dvr_gl.io import load_field
from dvr_gl.io.mesh import read_plot3d

pytest.importorskip("meshio", reason="meshes are read with meshio (pip install 'dvr-gl[mesh]')")

UNSTRUCTURED = SHARED_DATA / "unstructured"
needs_data = pytest.mark.skipif(not UNSTRUCTURED.is_dir(), reason=f"{UNSTRUCTURED} is absent (shared datasets)")

# file -> (points in the file, tetrahedra after splitting, zero-volume tetrahedra, association,
#          array, value range) from ../shared/data/README.md
FILES = {
    "bluntfin_tets.vtk": (40_960, 187_395, 77, "point", "density", (0.1926, 4.9775)),
    "comb_tets.vtk": (47_025, 215_040, 0, "point", "density", (0.1978, 0.7104)),
    "post_tets.vtk": (109_744, 513_375, 0, "point", "q4_energy", (-0.5415, 4.3958)),
    # 56,786 tetra10, eight linear tetrahedra each
    "kiefer_jaw_tet10.vtu": (102_578, 8 * 56_786, 0, "cell", None, (0.014, 23.27)),
    # 2,188 hexahedra (12 each) and 4 wedges (8 each), plus a centroid point per cell
    "notch_stress.vtk": (12_717 + 2_192, 12 * 2_188 + 8 * 4, 0, "point", None, (-1.45e5, 8.11e6)),
    "tetraMesh.vtk": (55, 160, 0, "point", None, None),
}


@needs_data
@pytest.mark.parametrize("name", list(FILES))
def test_every_shared_mesh_reads_as_its_readme_says(name):
    points, tets, degenerate, association, array, value_range = FILES[name]
    kwargs = {"array": array} if array and name != "post_tets.vtk" else {}
    if name == "post_tets.vtk":
        kwargs = {"array": "q4_energy"}
    mesh = load_field(UNSTRUCTURED / name, **kwargs)
    assert mesh.kind == "mesh"
    assert len(mesh.points) == points
    assert len(mesh.tets) + mesh.n_degenerate == tets
    assert mesh.n_degenerate == degenerate
    assert mesh.association == association
    if array:
        assert mesh.array == array
    if value_range:
        lo, hi = mesh.value_range
        scale = max(abs(value_range[0]), abs(value_range[1]))
        assert lo == pytest.approx(value_range[0], abs=1e-3 * scale)
        assert hi == pytest.approx(value_range[1], abs=1e-3 * scale)


@needs_data
def test_a_mesh_with_a_nan_array_defaults_to_a_finite_one_and_names_the_bad_one():
    """notch_stress's 'normed' array holds 9,180 NaNs: not chosen by default, refused by name."""
    path = UNSTRUCTURED / "notch_stress.vtk"
    mesh = load_field(path)
    assert np.isfinite(mesh.values).all()
    normed = next(k for k in __import__("meshio").read(str(path)).point_data if "normed" in k)
    with pytest.raises(DvrError, match="9180 NaN or Inf values; choose another array"):
        load_field(path, array=normed)
    with pytest.raises(DvrError, match="has 6 components; choose a one-component array"):
        load_field(path, array=next(k for k in __import__("meshio").read(str(path)).point_data
                                    if k.endswith("Stress")))


@needs_data
@pytest.mark.parametrize("stem, array, expected", [("bluntfin", "density", (0.1926, 4.9775)),
                                                   ("comb", "density", (0.1978, 0.7104)),
                                                   ("post", "energy", (-0.5415, 4.3958))])
def test_plot3d_grids_read_as_hexahedra(stem, array, expected):
    """The original PLOT3D grids: the same points and scalars as the tetrahedral files derived from
    them (README: 'DERIVED'), read as hexahedra (12 tetrahedra each)."""
    mesh = load_field(UNSTRUCTURED / f"{stem}xyz.bin", format="plot3d")
    assert mesh.array == array  # post's density is constant 1: the default falls to energy
    lo, hi = mesh.value_range
    assert (lo, hi) == pytest.approx(expected, abs=1e-3 * max(map(abs, expected)))
    derived = load_field(UNSTRUCTURED / f"{stem}_tets.vtk", array="q4_energy" if stem == "post" else "density")
    n = len(derived.points)
    np.testing.assert_array_equal(mesh.points[:n].astype(np.float32), derived.points.astype(np.float32))
    np.testing.assert_array_equal(mesh.values[:n].astype(np.float32), derived.values.astype(np.float32))


@needs_data
def test_plot3d_points_are_located_in_their_cells():
    """At the grid's own points the field is the point's value, whichever of the cells sharing the
    point is found (inside a cell the hexahedral and the five-tetrahedra splits differ: two linear
    splits of one trilinear cell)."""
    hexes = load_field(UNSTRUCTURED / "bluntfinxyz.bin", format="plot3d").reconstruct()
    corners = hexes.mesh.points[:40_960:97]
    expected = hexes.mesh.values[:40_960:97]
    # a grid point lies on several cells: whichever is found, the value there is the point's
    np.testing.assert_allclose(hexes.sample(corners), expected, rtol=1e-6, atol=1e-6)


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text) if isinstance(text, str) else path.write_bytes(text)
    return path


TET_HEADER = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n"


@pytest.mark.parametrize("case, text, message", [
    ("truncated", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0\n", "not a readable VTK unstructured grid"),
    ("surface only", TET_HEADER + "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nCELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n5\n"
     "POINT_DATA 3\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3\n", "no volume cells"),
    ("no scalars", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
     "no one-component array"),
    ("bad index", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 9\nCELL_TYPES 1\n10\n"
     "POINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3 4\n", "outside 0..3"),
    ("quadratic hexahedron", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\n"
     "CELL_TYPES 1\n25\n", "not a readable VTK unstructured grid"),  # meshio knows no type 25
])
def test_malformed_mesh_files_are_one_line_errors(tmp_path, case, text, message):
    path = _write(tmp_path, "bad.vtk", text)
    with pytest.raises(DvrError, match=message) as info:
        load_field(path)
    assert "\n" not in str(info.value)


def test_grid_options_on_a_mesh_and_mesh_options_on_a_grid_are_refused(tmp_path):
    path = _write(tmp_path, "t.vtk", TET_HEADER + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\n"
                  "CELL_TYPES 1\n10\nPOINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n1 2 3 4\n")
    assert load_field(path).describe().startswith("t.vtk: mesh, 4 points, 1 tetrahedra")
    with pytest.raises(DvrError, match="volume.spacing applies to regular grids"):
        load_field(path, spacing=(1, 1, 1))
    np.save(tmp_path / "g.npy", np.zeros((2, 2, 2), np.float32))
    with pytest.raises(DvrError, match="volume.array applies to meshes"):
        load_field(tmp_path / "g.npy", array="s")


@pytest.mark.parametrize("case, message", [("short", "too short for a PLOT3D header"),
                                           ("size", "bytes, but a 2x2x2 grid needs"),
                                           ("dims", "solution dimensions"),
                                           ("no q", "no solution file")])
def test_malformed_plot3d_is_refused_in_one_line(tmp_path, case, message):
    dims = np.array([2, 2, 2], ">i4").tobytes()
    xyz = dims + np.zeros(24, ">f4").tobytes()
    q = dims + np.zeros(4, ">f4").tobytes() + np.ones(40, ">f4").tobytes()
    if case == "short":
        xyz = dims[:8]
    elif case == "size":
        xyz = xyz[:-4]
    elif case == "dims":
        q = np.array([3, 2, 2], ">i4").tobytes() + q[12:]
    _write(tmp_path, "gxyz.bin", xyz)
    if case != "no q":
        _write(tmp_path, "gq.bin", q)
    with pytest.raises(DvrError, match=message):
        read_plot3d(tmp_path / "gxyz.bin")
