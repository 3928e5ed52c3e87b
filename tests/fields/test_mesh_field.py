"""The tetrahedral mesh as a field: cell splitting without cracks, orientation and degenerate cells,
point location, and the exact pieces of rays through the cells."""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl import limits
from dvr_gl.errors import SceneError, VolumeError
from dvr_gl.fields.mesh import TetMesh
from dvr_gl.fields.mesh_cells import hexahedra_of_grid, split_quads, tetrahedralize
from dvr_gl.rays import intersect_box


def grid_points(n=(3, 3, 3), size=(1.0, 1.2, 1.4), jitter=0.0, seed=0):
    """Points of an ``n`` grid over a box (i fastest), interior points moved by ``jitter`` cells."""
    axes = [np.linspace(0.0, s, k) for s, k in zip(size, n)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    if jitter:
        rng = np.random.default_rng(seed)
        interior = np.all([(p[:, i] > 0) & (p[:, i] < size[i]) for i in range(3)], axis=0)
        step = np.array(size) / (np.array(n) - 1)
        p[interior] += rng.uniform(-jitter, jitter, (interior.sum(), 3)) * step
    return p


def hex_mesh(n=(3, 3, 3), size=(1.0, 1.2, 1.4), jitter=0.0, values=None, shuffle=False, seed=0):
    """A grid of hexahedra split into tetrahedra: ``(points, tets, values)``; ``shuffle``: renumber
    the points at random (the split must not depend on a numbering)."""
    p = grid_points(n, size, jitter, seed)
    hexes = hexahedra_of_grid(*n)
    if shuffle:
        perm = np.random.default_rng(seed).permutation(len(p))
        inverse = np.argsort(perm)
        p, hexes = p[perm], inverse[hexes]
    v = values(p) if values is not None else p[:, 0]
    points, tets, _, v = tetrahedralize(p, [("hexahedron", hexes)], v)
    return points, tets, v


def faces_of(tets):
    f = np.concatenate([np.delete(tets, k, axis=1) for k in range(4)])
    return np.sort(f, axis=1)


def signed_volumes(points, tets):
    e = points[tets[:, 1:]] - points[tets[:, :1]]
    return np.einsum("ni,ni->n", e[:, 0], np.cross(e[:, 1], e[:, 2])) / 6.0


# --- cells -------------------------------------------------------------------------------------

def test_quads_split_by_their_indices_alone():
    """The same quadrilateral, listed from any corner and either way round, splits along one diagonal."""
    quad = np.array([7, 3, 11, 5])
    splits = set()
    for k in range(4):
        for q in (np.roll(quad, k), np.roll(quad[::-1], k)):
            tri = split_quads(q[None, :])
            splits.add(frozenset(frozenset(t) for t in tri.tolist()))
    assert len(splits) == 1
    (split,) = splits
    assert all(3 in t for t in split), "the diagonal runs through the smallest index"


@pytest.mark.parametrize("shuffle", [False, True])
def test_hexahedra_split_without_cracks(shuffle):
    """Every interior triangle is shared by exactly two tetrahedra and the boundary is the box's
    quadrilaterals, two triangles each; the tetrahedra fill the cells' volume exactly."""
    n = (4, 3, 3)
    points, tets, _ = hex_mesh(n, jitter=0.2, shuffle=shuffle, seed=3)
    faces, counts = np.unique(faces_of(tets), axis=0, return_counts=True)
    assert set(counts.tolist()) <= {1, 2}
    boundary_quads = 2 * ((n[0] - 1) * (n[1] - 1) + (n[1] - 1) * (n[2] - 1) + (n[0] - 1) * (n[2] - 1))
    assert (counts == 1).sum() == 2 * boundary_quads
    volume = np.abs(signed_volumes(points, tets)).sum()
    assert volume == pytest.approx(1.0 * 1.2 * 1.4, rel=1e-12)  # jitter moves interior points only
    assert len(tets) == 12 * (n[0] - 1) * (n[1] - 1) * (n[2] - 1)


def test_wedges_and_pyramids_share_faces_with_hexahedra():
    """A hexahedron, a wedge on one of its faces and a pyramid on another: no cracks between them."""
    cube = grid_points((2, 2, 2))  # points 0..7, i fastest
    hexa = hexahedra_of_grid(2, 2, 2)[0]  # VTK order
    top = np.array([[0, 0, 2.0], [1, 0, 2.0]])  # a ridge above the top face: a wedge (5 faces)
    apex = np.array([[0.5, 0.5, -1.0]])          # a pyramid below the bottom face
    points = np.concatenate([cube, top, apex])
    wedge = np.array([hexa[4], hexa[7], 8, hexa[5], hexa[6], 9])  # triangles (4,7,8), (5,6,9)
    pyramid = np.array([hexa[0], hexa[1], hexa[2], hexa[3], 10])
    p, tets, parent, _ = tetrahedralize(points, [("hexahedron", hexa[None]), ("wedge", wedge[None]),
                                                 ("pyramid", pyramid[None])])
    assert np.bincount(parent).tolist() == [12, 8, 2]
    faces, counts = np.unique(faces_of(tets), axis=0, return_counts=True)
    assert set(counts.tolist()) <= {1, 2}
    shared = faces[counts == 2]
    on_top = np.all(np.isin(shared, hexa[4:]), axis=1).sum()
    on_bottom = np.all(np.isin(shared, hexa[:4]), axis=1).sum()
    assert on_top == 2 and on_bottom == 2, "the shared quadrilaterals are split the same way from both sides"


def test_tetra10_splits_into_eight_through_the_mid_edge_nodes():
    rng = np.random.default_rng(1)
    corners = rng.normal(size=(4, 3))
    mids = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    points = np.concatenate([corners, [(corners[i] + corners[j]) / 2 for i, j in mids]])
    p, tets, parent, _ = tetrahedralize(points, [("tetra10", np.arange(10)[None])])
    assert len(tets) == 8 and (parent == 0).all()
    vol = np.abs(signed_volumes(p, tets))
    whole = abs(signed_volumes(points, np.arange(4)[None]))[0]
    np.testing.assert_allclose(vol, whole / 8, rtol=1e-10)  # each child is an eighth
    faces, counts = np.unique(faces_of(tets), axis=0, return_counts=True)
    assert (counts == 1).sum() == 16, "the boundary is the parent's four faces, four triangles each"


# --- the field ---------------------------------------------------------------------------------

def test_orientation_is_made_positive_and_degenerate_cells_are_counted():
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0.0], [1, 1, 1.0]], float)
    tets = np.array([[0, 2, 1, 3],      # negative: flipped
                     [0, 1, 2, 4],      # flat (all four in z = 0): zero volume
                     [1, 2, 3, 5]])
    mesh = TetMesh(points, tets, points[:, 0])
    assert mesh.n_degenerate == 1 and len(mesh.tets) == 2
    assert (signed_volumes(mesh.points, mesh.tets) > 0).all()
    assert "1 of zero volume" in mesh.describe()
    assert mesh.value_range == (0.0, 1.0)


@pytest.mark.parametrize("case, message", [
    ("nan", "NaN or Inf values"), ("range", "outside 0.."), ("count", "has 3 values for 4 points"),
    ("flat", "all 1 tetrahedra have zero volume")])
def test_bad_meshes_are_refused_in_one_line(case, message):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    tets = np.array([[0, 1, 2, 3]])
    values = np.arange(4.0)
    if case == "nan":
        values[2] = np.nan
    elif case == "range":
        tets = np.array([[0, 1, 2, 4]])
    elif case == "count":
        values = values[:3]
    elif case == "flat":
        points[3, 2] = 0.0
    with pytest.raises(VolumeError, match=message):
        TetMesh(points, tets, values)


def test_a_mesh_reconstructs_linearly_only():
    points, tets, v = hex_mesh((2, 2, 2))
    with pytest.raises(SceneError, match="filter = \"linear\""):
        TetMesh(points, tets, v).reconstruct("cubic_bspline")


def test_linear_data_is_reproduced_and_located():
    """Point scalars of a linear function are that function everywhere inside; NaN outside."""
    f = lambda p: 0.3 + 2.0 * p[:, 0] - 1.5 * p[:, 1] + 0.25 * p[:, 2]  # noqa: E731
    points, tets, v = hex_mesh((4, 3, 5), jitter=0.25, values=f, seed=2)
    field = TetMesh(points, tets, v).reconstruct()
    rng = np.random.default_rng(0)
    inside = rng.uniform([0, 0, 0], [1.0, 1.2, 1.4], (2000, 3))
    np.testing.assert_allclose(field.sample(inside), f(inside), atol=1e-12)
    np.testing.assert_allclose(field.gradient(inside), np.tile([2.0, -1.5, 0.25], (2000, 1)), atol=1e-10)
    outside = inside + np.array([1.5, 0, 0])
    assert np.isnan(field.sample(outside)).all()


# --- rays through the cells --------------------------------------------------------------------

def _rays(kind, n=400, seed=0):
    rng = np.random.default_rng(seed)
    if kind == "perspective":
        eye = np.array([2.5, -1.8, 2.2])
        target = rng.uniform([0, 0, 0], [1.0, 1.2, 1.4], (n, 3))
        d = target - eye
        o = np.tile(eye, (n, 1))
    else:
        d = np.tile(np.array([-0.6, 0.7, -0.4]), (n, 1))
        o = rng.uniform([0, 0, 0], [1.0, 1.2, 1.4], (n, 3)) - 3.0 * d
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
def test_pieces_tile_the_chord_exactly(kind):
    """In a convex mesh, each ray's pieces run end to end from box entry to exit: consecutive pieces
    meet at the same float64 number (shared faces give identical planes), and their values agree
    there (the field is continuous)."""
    points, tets, v = hex_mesh((4, 3, 3), jitter=0.2, shuffle=True, seed=5)
    field = TetMesh(points, tets, v).reconstruct()
    o, d = _rays(kind)
    t0, t1 = intersect_box(o, d, np.zeros(3), np.array([1.0, 1.2, 1.4]))
    hit = t1 > t0
    ray, a, b, cell = field.pieces(o, d, np.where(hit, t0, 0), np.where(hit, t1, 0))
    assert set(np.unique(ray)) == set(np.nonzero(hit)[0])
    same = ray[1:] == ray[:-1]
    assert np.array_equal(a[1:][same], b[:-1][same]), "pieces meet exactly"
    first = np.r_[True, ~same]
    last = np.r_[~same, True]
    np.testing.assert_allclose(a[first], t0[ray[first]], atol=1e-12)
    np.testing.assert_allclose(b[last], t1[ray[last]], atol=1e-12)
    at_b = field.sample_cells(cell[:-1][same], o[ray[:-1][same]] + b[:-1][same, None] * d[ray[:-1][same]])
    at_a = field.sample_cells(cell[1:][same], o[ray[1:][same]] + a[1:][same, None] * d[ray[1:][same]])
    np.testing.assert_allclose(at_a, at_b, atol=1e-12)


def test_pieces_skip_the_gaps_of_a_non_convex_mesh():
    """Two boxes with a gap between: a ray through both has pieces in each and none in the gap."""
    p1, t1_, v1 = hex_mesh((2, 2, 2), size=(1.0, 1.0, 1.0))
    p2, t2_, v2 = hex_mesh((2, 2, 2), size=(1.0, 1.0, 1.0))
    p2 = p2 + np.array([2.0, 0.0, 0.0])
    mesh = TetMesh(np.concatenate([p1, p2]), np.concatenate([t1_, t2_ + len(p1)]), np.concatenate([v1, v2]))
    field = mesh.reconstruct()
    o = np.array([[-1.0, 0.3, 0.6], [-1.0, 0.5, 0.5]])
    d = np.array([[1.0, 0.0, 0.0], [1.0, 0.01, -0.01]])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ray, a, b, _ = field.pieces(o, d, np.array([0.0, 0.0]), np.array([10.0, 10.0]))
    length = np.bincount(ray, b - a)
    np.testing.assert_allclose(length[0], 2.0, atol=1e-12)
    assert not np.any((a < 3.0 - 1e-12) & (b > 2.0 + 1e-12) & (ray == 0)), "nothing in the gap x in (1, 2): t in (2, 3)"
    assert length[1] == pytest.approx(2.0 / d[1, 0], rel=1e-12)
    # rays through the box that meet no cell (down the gap) have no pieces, and nothing fails
    gap_o = np.array([[1.5, -1.0, 0.5], [1.3, -1.0, 0.2]])
    gap_d = np.tile([0.0, 1.0, 0.0], (2, 1))
    assert all(len(x) == 0 for x in field.pieces(gap_o, gap_d, np.zeros(2), np.full(2, 3.0)))


def test_degenerate_cells_bound_no_piece():
    """A zero-volume tetrahedron inside a mesh (a collapsed cell, as in the blunt fin) changes nothing."""
    points, tets, v = hex_mesh((3, 3, 3))
    # a flat cell on an interior face: three of its vertices and the face's own centre point
    face = np.sort(tets[0, :3])
    centre = points[face].mean(axis=0)
    points2 = np.concatenate([points, centre[None]])
    tets2 = np.concatenate([tets, [[face[0], face[1], face[2], len(points)]]])
    v2 = np.concatenate([v, [centre[0]]])
    mesh = TetMesh(points2, tets2, v2)
    assert mesh.n_degenerate == 1
    o, d = _rays("perspective", 200, seed=4)
    t0, t1 = intersect_box(o, d, np.zeros(3), np.array([1.0, 1.2, 1.4]))
    t0, t1 = np.where(t1 > t0, t0, 0), np.where(t1 > t0, t1, 0)
    ray, a, b, _ = mesh.reconstruct().pieces(o, d, t0, t1)
    np.testing.assert_allclose(np.bincount(ray, b - a, minlength=len(o)), t1 - t0, atol=1e-12)


def test_resampling_reproduces_linear_data_and_marks_the_outside():
    """Grid points inside take the mesh's value (exact for a linear field); points in a gap take the
    outside value, below the range, which the resampled scene's transfer function makes transparent."""
    from dvr_gl.fields.mesh_resample import outside_value, resample

    p1, t1_, _ = hex_mesh((2, 2, 2), size=(1.0, 1.0, 1.0))
    p2 = p1 + np.array([2.0, 0.0, 0.0])
    points = np.concatenate([p1, p2])
    f = lambda p: 1.0 + 0.5 * p[:, 0] - 0.25 * p[:, 2]  # noqa: E731
    mesh = TetMesh(points, np.concatenate([t1_, t1_ + len(p1)]), f(points))
    grid = resample(mesh, 31)  # spacing 0.1 over x in [0, 3]
    assert grid.dims == (31, 11, 11)
    z, y, x = np.meshgrid(*(np.arange(n) * 0.1 for n in grid.dims[::-1]), indexing="ij")
    inside = (x <= 1.0 + 1e-9) | (x >= 2.0 - 1e-9)
    expected = f(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)).reshape(x.shape)
    np.testing.assert_allclose(grid.data[inside], expected[inside], atol=1e-6)  # float32
    assert np.all(grid.data[~inside] == np.float32(outside_value(mesh)))
    assert outside_value(mesh) < mesh.value_range[0]


def test_resampling_is_checked_before_anything_is_allocated(monkeypatch):
    """Issue 40: --resample 1024 made a 7 GiB allocation with no estimate first.  The grid is float32
    (4 bytes a point, located slab by slab), refused over the memory budget, and its point-in-cell
    tests (counted from the locator's bins, exactly) over the work bound, in one line each."""
    import dvr_gl.fields.mesh_resample as mr
    from dvr_gl.sandbox import Sandbox, SandboxError, active

    points, tets, values = hex_mesh((4, 4, 4), size=(1.0, 1.0, 1.0))
    mesh = TetMesh(points, tets, values)
    with active(Sandbox(max_bytes=256 << 20)), pytest.raises(SandboxError, match=r"resampling mesh onto "
                                                             r"1024x1024x1024 points .* would take 4.14 GiB"):
        mesh.resampled(1024)
    locator = mesh.reconstruct().locator
    work = mr.check_resample(mesh, 40, locator)
    grid = mr.resample(mesh, 40)
    counted = {"n": 0}
    real = type(locator).locate

    def counting(self, p):  # the candidates locate really tests: what the estimate counted
        key = self._key(self._bin(p[np.all((p >= self.lo) & (p <= self.hi), axis=1)]))
        counted["n"] += int((self.start[key + 1] - self.start[key]).sum())
        return real(self, p)

    monkeypatch.setattr(type(locator), "locate", counting)
    assert np.array_equal(mr.resample(mesh, 40).data, grid.data) and counted["n"] == work
    monkeypatch.setitem(limits.BOUNDS, mr.RESAMPLE_WORK, work / 2)
    with pytest.raises(SceneError, match=r"would take .* point-in-cell tests .* over the bound of .*; lower "
                                         r"--resample"):
        mesh.resampled(40)


def test_resampling_reports_progress_by_slabs(monkeypatch):
    import dvr_gl.fields.mesh_resample as mr
    from dvr_gl import progress

    points, tets, values = hex_mesh((3, 3, 3), size=(1.0, 1.0, 1.0))
    monkeypatch.setattr(mr, "POINTS_PER_SLAB", 64)  # 8x8 points a slice: one slice a slab
    seen = []
    with progress.reporting(lambda done, total: seen.append((done, total))):
        TetMesh(points, tets, values).resampled(8)
    assert seen[-1] == (8, 8) and len(seen) == 8
