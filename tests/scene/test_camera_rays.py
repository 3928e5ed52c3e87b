import math

import numpy as np
import pytest

from dvr_gl.camera import Camera, framing_distance, orbit_of
from dvr_gl.errors import SceneError
from dvr_gl.gl.geometry import box_corners
from dvr_gl.rays import RayBatch, intersect_box, jitter_offsets, pcg_hash, segment_bounds, segment_counts


def test_orbit_conventions():
    c = Camera.from_orbit((0, 0, 0), (0, 0, 1), 0.0, 0.0, 2.0)
    np.testing.assert_allclose(c.eye, [0, -2, 0], atol=1e-15)  # azimuth 0: on the -y side
    c = Camera.from_orbit((0, 0, 0), (0, 0, 1), 90.0, 0.0, 2.0)
    np.testing.assert_allclose(c.eye, [2, 0, 0], atol=1e-15)   # azimuth turns toward +x
    c = Camera.from_orbit((1, 1, 1), (0, 0, 1), 0.0, 90.0, 3.0)
    np.testing.assert_allclose(c.eye, [1, 1, 4], atol=1e-15)   # elevation lifts toward up


@pytest.mark.parametrize("az, el", [(0, 0), (33, -20), (-170, 75), (120, 10)])
def test_orbit_of_inverts_orbit(az, el):
    c = Camera.from_orbit((1, 2, 3), (0, 0.3, 1), az, el, 5.0)
    np.testing.assert_allclose(orbit_of(c.eye, c.target, c.up), (az, el, 5.0), atol=1e-9)


@pytest.mark.parametrize("el", [90.0, -90.0])
def test_looking_along_up_has_a_valid_basis(el):
    c = Camera.from_orbit((0, 0, 0), (0, 0, 1), 30.0, el, 2.0)
    f, r, u = c.basis()
    assert np.all(np.isfinite([f, r, u]))
    np.testing.assert_allclose(np.cross(r, u), -f, atol=1e-12)
    # continuous with a view just off the pole
    _, r_near, _ = Camera.from_orbit((0, 0, 0), (0, 0, 1), 30.0, el - np.sign(el) * 1e-6, 2.0).basis()
    np.testing.assert_allclose(r, r_near, atol=1e-5)


def test_perspective_rays_through_pixel_centres():
    c = Camera((0, -5, 0), (0, 0, 0), (0, 0, 1), fov=60.0)
    o, d = c.pixel_rays(3, 3)
    np.testing.assert_allclose(d[4], [0, 1, 0])  # the centre pixel looks at the target
    # row 0 is the top: its rays point up; the pixel centre sits 2/3 of the half height up
    assert d[1, 2] > 0 and d[7, 2] < 0
    assert math.degrees(math.atan2(d[1, 2], d[1, 1])) == pytest.approx(math.degrees(
        math.atan(math.tan(math.radians(30)) * 2 / 3)))
    assert d[5, 0] > 0  # column 2 is to the right (+x, looking along +y with z up)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)


def test_orthographic_rays_are_parallel_and_span_the_view_height():
    c = Camera((0, -5, 0), (0, 0, 0), (0, 0, 1), projection="orthographic", view_height=4.0)
    o, d = c.pixel_rays(4, 2)
    np.testing.assert_allclose(d, np.tile([0, 1, 0], (8, 1)))
    assert o[0, 2] == pytest.approx(1.0) and o[4, 2] == pytest.approx(-1.0)   # rows at +-h/4
    assert o[0, 0] == pytest.approx(-3.0) and o[3, 0] == pytest.approx(3.0)   # aspect 2


def test_default_framing_keeps_the_box_in_view():
    lo, hi = np.zeros(3), np.array([10.0, 20.0, 5.0])
    radius = np.linalg.norm(hi - lo) / 2
    for aspect in (0.5, 1.0, 2.0):
        dist = framing_distance(radius, 30.0, aspect)
        c = Camera.from_orbit((hi + lo) / 2, (0, 0, 1), 30, 20, dist, fov=30.0)
        f, r, u = c.basis()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        rel = corners - np.array(c.eye)
        depth = rel @ f
        half_v = math.tan(math.radians(15))
        assert np.all(np.abs(rel @ u / depth) < half_v)
        assert np.all(np.abs(rel @ r / depth) < half_v * aspect)


def test_bad_camera_values():
    with pytest.raises(SceneError, match="fov"):
        Camera((0, -1, 0), (0, 0, 0), fov=180)
    with pytest.raises(SceneError, match="target - eye"):
        Camera((0, 0, 0), (0, 0, 0))
    with pytest.raises(SceneError, match="up"):
        Camera((0, -1, 0), (0, 0, 0), up=(0, 0, 0))


def test_box_intersection_hits_misses_and_grazes():
    o = np.array([[-1.0, 0.5, 0.5], [-1.0, 2.0, 0.5], [-1.0, 1.0, 0.5], [0.5, 0.5, 0.5], [-1.0, 1.0, 1.0]])
    d = np.array([[1.0, 0, 0]] * 5)
    t0, t1 = intersect_box(o, d, np.zeros(3), np.ones(3))
    np.testing.assert_allclose(t0[[0, 2, 3, 4]], [1.0, 1.0, -0.5, 1.0])
    np.testing.assert_allclose(t1[[0, 2, 3, 4]], [2.0, 2.0, 0.5, 2.0])
    assert t1[1] < t0[1]  # miss
    # rays 2 and 4 run along a face and an edge of the closed box: inside, no NaN


def test_near_plane_and_camera_inside():
    c = Camera((0.5, 0.5, 0.5), (0.5, 2.0, 0.5), (0, 0, 1), near=0.1)
    rays = RayBatch.for_camera(c, 1, 1, (np.zeros(3), np.ones(3)))
    assert rays.t0[0] == pytest.approx(0.1) and rays.t1[0] == pytest.approx(0.5)


def test_segments_tile_the_ray_and_the_last_is_shortened():
    t0, t1, d = np.array([0.3, 0.0, 1.0]), np.array([1.35, 1.0, 1.0]), 0.25
    n = segment_counts(t0, t1, d)
    np.testing.assert_array_equal(n, [5, 4, 0])
    start, length = segment_bounds(t0[0], t1[0], np.arange(5), d)
    np.testing.assert_allclose(length, [0.25, 0.25, 0.25, 0.25, 0.05])
    assert start[-1] + length[-1] == pytest.approx(t1[0], abs=1e-15)


def _pcg_reference(v: int) -> int:
    """The PCG hash in plain Python integers (independent of numpy's uint32 arithmetic)."""
    state = (v * 747796405 + 2891336453) & 0xFFFFFFFF
    word = (((state >> ((state >> 28) + 4)) ^ state) * 277803737) & 0xFFFFFFFF
    return (word >> 22) ^ word


def test_pcg_hash_matches_plain_integer_arithmetic():
    vals = np.array([0, 1, 2, 12345, 2**31, 2**32 - 1], dtype=np.uint32)
    assert pcg_hash(vals).tolist() == [_pcg_reference(int(v)) for v in vals]


def test_jitter_offsets_are_deterministic_uniform_and_float32_exact():
    j = jitter_offsets(64, 48, seed=3)
    assert j.shape == (64 * 48,) and j.min() >= 0 and j.max() < 1
    np.testing.assert_array_equal(j, jitter_offsets(64, 48, seed=3))
    assert not np.array_equal(j, jitter_offsets(64, 48, seed=4))
    np.testing.assert_array_equal(j.astype(np.float32).astype(np.float64), j)
    assert abs(j.mean() - 0.5) < 0.02


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_pixel_rectangle_holds_every_pixel_whose_ray_meets_the_box(projection):
    """Camera.pixel_rectangle (the ray caster's scissor box) holds every pixel whose ray through its centre meets
    a box, on random views, near and far, off-centre and partly outside the image (rows counted from the
    bottom): a pixel left out would be drawn empty.  Far views leave most of the image out."""
    rng = np.random.default_rng(7)
    lo, hi = np.array([-1.0, -0.5, -0.25]), np.array([1.0, 0.5, 0.25])
    width, height = 37, 23
    smaller = 0
    for _ in range(60):
        target = rng.uniform(-1.5, 1.5, 3)
        camera = Camera.from_orbit(tuple(target), (0, 0, 1), rng.uniform(-180, 180), rng.uniform(-80, 80),
                                   rng.uniform(2.0, 12.0), projection=projection, fov=rng.uniform(10, 90),
                                   view_height=rng.uniform(0.5, 6.0))
        rect = camera.pixel_rectangle(box_corners(lo, hi), width, height)
        assert rect is not None
        x, y, w, h = rect
        assert 0 <= x and 0 <= y and w >= 0 and h >= 0 and x + w <= width and y + h <= height
        o, d = camera.pixel_rays(width, height)
        t0, t1 = intersect_box(o, d, lo, hi)
        hit = np.nonzero(t1 >= np.maximum(t0, 0.0))[0]
        cols, rows = hit % width, height - 1 - hit // width  # GL's rows count from the bottom
        assert np.all((cols >= x) & (cols < x + w) & (rows >= y) & (rows < y + h))
        smaller += w * h < width * height / 2
    assert smaller >= 10


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_pixel_rectangle_of_a_face_on_box_is_its_pixels_and_the_margin(projection):
    """Seen face on (along z), a box projects to a rectangle (perspective: its near face's, which holds the far
    one's): the scissor box is exactly its pixels' bounding box widened by the margin, one pixel each side."""
    lo, hi = np.array([-0.83, -0.31, -0.4]), np.array([0.52, 0.77, 0.4])
    camera = Camera(eye=(0.1, 0.05, 4.0), target=(0.1, 0.05, 0.0), up=(0.0, 1.0, 0.0), projection=projection,
                    fov=40.0, view_height=3.0)
    width, height = 61, 47
    o, d = camera.pixel_rays(width, height)
    t0, t1 = intersect_box(o, d, lo, hi)
    hit = np.nonzero(t1 >= np.maximum(t0, 0.0))[0]
    cols, rows = hit % width, height - 1 - hit // width
    x, y, w, h = camera.pixel_rectangle(box_corners(lo, hi), width, height)
    assert (x, y, x + w - 1, y + h - 1) == (cols.min() - 1, rows.min() - 1, cols.max() + 1, rows.max() + 1)


def test_pixel_rectangle_cannot_tell_with_the_eye_inside_or_behind():
    """A point at or behind the eye's plane projects nowhere (the eye inside the box, or the box behind it):
    None, every pixel drawn; a box in front of the eye but beside the view leaves no pixel."""
    corners = box_corners((-1, -1, -1), (1, 1, 1))
    inside = Camera(eye=(0.2, 0.1, 0.0), target=(1.0, 0.0, 0.0))
    assert inside.pixel_rectangle(corners, 16, 16) is None
    behind = Camera(eye=(0.0, -3.0, 0.0), target=(0.0, -6.0, 0.0))
    assert behind.pixel_rectangle(corners, 16, 16) is None
    beside = Camera(eye=(0.0, -10.0, 0.0), target=(4.0, 0.0, 0.0), fov=10.0)  # the box 22 degrees off the axis
    x, y, w, h = beside.pixel_rectangle(corners, 16, 16)
    o, d = beside.pixel_rays(16, 16)
    t0, t1 = intersect_box(o, d, (-1, -1, -1), (1, 1, 1))
    assert w * h == 0 and not np.any(t1 >= np.maximum(t0, 0.0))
