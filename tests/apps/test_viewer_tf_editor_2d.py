"""The viewer's 2D editor's model without a window: its table is from_boxes' and its histogram histogram_2d's."""
import numpy as np
import pytest

from dvr_gl.renderers.registry import plugins
from dvr_gl.transfer_function_2d import TransferFunction2D, histogram_2d
from dvr_gl.viewer.tf_editor_2d import BoxEditor2D, renders_2d


@pytest.fixture
def data():
    z, y, x = np.mgrid[:12, :12, :12]
    return np.sqrt((x - 5.5) ** 2 + (y - 5.5) ** 2 + (z - 5.5) ** 2)


def test_histogram_axes_match_histogram_2d(data):
    ed = BoxEditor2D(data, (1.0, 1.0, 1.0), bins=(32, 16))
    counts, vr, gr = histogram_2d(data, (1.0, 1.0, 1.0), bins=(32, 16))
    assert ed.value_range == vr and ed.gradient_range == gr
    np.testing.assert_array_equal(ed.log_counts, np.log1p(counts))


def test_edits_build_the_table_from_boxes_would(data):
    ed = BoxEditor2D(data, (1.0, 1.0, 1.0), bins=(32, 16))
    assert not ed.transfer_function.table[..., 3].any()  # no box: transparent
    i = ed.add(4.0, 0.5)
    ed.move(i, 3.0, 0.2)
    ed.resize(i, 2.0, 0.8)
    ed.set_color(i, (1.0, 0.5, 0.0))
    ed.set_opacity(i, 0.7)
    j = ed.add(1.0, 0.1)
    assert ed.pick(4.0, 0.6) == i
    ed.delete(j)
    assert ed.boxes == [[3.0, 0.2, 2.0, 0.8, 1.0, 0.5, 0.0, 0.7]]
    want = TransferFunction2D.from_boxes(ed.boxes, ed.value_range, ed.gradient_range, (32, 16))
    np.testing.assert_array_equal(ed.transfer_function.table, want.table)  # the same arithmetic: bit-equal
    keys = ed.scene_keys()
    again = TransferFunction2D.from_boxes(keys["boxes_2d"], keys["value_range_2d"], keys["gradient_range_2d"],
                                          keys["size_2d"])
    np.testing.assert_array_equal(again.table, want.table)


def test_trait_decides_the_mode():
    declared = {n for n, p in plugins().items() if "grid" in p.transfer_function_2d}
    assert declared, "some renderer declares a 2D transfer function on grids"
    assert all(renders_2d(n) == (n in declared) for n in plugins())


def test_the_editors_scene_is_checked_as_a_scene_files(data):
    """The viewer's path for an edit (with_transfer_function, then the registry's check): a renderer with the trait
    takes the 2D function; one without it refuses in one line naming those that take it."""
    from dvr_gl.api import scene_of
    from dvr_gl.errors import SceneError
    from dvr_gl.renderers.registry import check
    from dvr_gl.viewer.timeline import with_transfer_function

    ed = BoxEditor2D(data.astype(np.float32), (1.0, 1.0, 1.0), bins=(32, 16))
    ed.add(4.0, 0.5)
    scene = with_transfer_function(scene_of(data.astype(np.float32)), 0, ed.transfer_function)
    for name in plugins():
        if renders_2d(name):
            check(scene, name)
        elif plugins()[name].data_kinds is None or "grid" in plugins()[name].data_kinds:
            with pytest.raises(SceneError, match="2D transfer function"):
                check(scene, name)


# --- the mouse on the canvas (geometry on the model, no window) ---

def canvas_for(ed):
    """A 200 x 100 pixel canvas at (10, 20) over the editor's ranges."""
    from dvr_gl.viewer.tf_editor_2d import Canvas2D

    return Canvas2D(10.0, 20.0, 200.0, 100.0, ed.value_range, ed.gradient_range)


def test_canvas_round_trip_and_orientation(data):
    ed = BoxEditor2D(data, (1.0, 1.0, 1.0), bins=(32, 16))
    c = canvas_for(ed)
    (v0, v1), (g0, g1) = ed.value_range, ed.gradient_range
    assert c.to_pixel(v0, g0) == pytest.approx((10.0, 120.0))   # value 0 left, gradient 0 at the bottom
    assert c.to_pixel(v1, g1) == pytest.approx((210.0, 20.0))
    assert c.from_pixel(*c.to_pixel(0.3 * v1, 0.7 * g1)) == pytest.approx((0.3 * v1, 0.7 * g1), rel=1e-12)


def test_hit_tells_inside_edges_and_corners(data):
    ed = BoxEditor2D(data, (1.0, 1.0, 1.0), bins=(32, 16))
    c = canvas_for(ed)
    i = ed.add(*c.from_pixel(110.0, 70.0))      # a box of 20 x 10 pixels centred at (110, 70)
    left, top, right, bottom = c.box_rect(ed.boxes[i])
    assert (left, top, right, bottom) == pytest.approx((100.0, 65.0, 120.0, 75.0))
    assert ed.hit(c, 110, 70) == (i, "inside")
    assert ed.hit(c, 100.5, 70) == (i, "l") and ed.hit(c, 123, 70) == (i, "r")
    assert ed.hit(c, 110, 64) == (i, "t") and ed.hit(c, 110, 75) == (i, "b")
    assert ed.hit(c, 119, 74) == (i, "br") and ed.hit(c, 101, 66) == (i, "tl")
    assert ed.hit(c, 140, 70) is None and ed.hit(c, 110, 90) is None
    j = ed.add(*c.from_pixel(115.0, 70.0))      # on top of the first: it is picked first
    assert ed.hit(c, 112, 70) == (j, "inside")


def test_drag_moves_and_resizes_the_grabbed_box(data):
    ed = BoxEditor2D(data, (1.0, 1.0, 1.0), bins=(32, 16))
    c = canvas_for(ed)
    i = ed.add(*c.from_pixel(110.0, 70.0))
    grabbed = list(ed.boxes[i])
    ed.drag(i, "inside", grabbed, 30.0, -10.0, c)   # right 30 pixels, up 10: the box moves, its size kept
    assert c.box_rect(ed.boxes[i]) == pytest.approx((130.0, 55.0, 150.0, 65.0))
    grabbed = list(ed.boxes[i])
    ed.drag(i, "br", grabbed, 10.0, 5.0, c)          # the bottom-right corner: the top-left stays
    assert c.box_rect(ed.boxes[i]) == pytest.approx((130.0, 55.0, 160.0, 70.0))
    grabbed = list(ed.boxes[i])
    ed.drag(i, "l", grabbed, 500.0, 0.0, c)          # the left edge past the right: kept at the least width
    left, top, right, bottom = c.box_rect(ed.boxes[i])
    assert right == pytest.approx(160.0) and (right - left) == pytest.approx(0.005 * 200)
    assert (top, bottom) == pytest.approx((55.0, 70.0))
    assert ed.selected == i and ed.version == 4  # add and three drags: each an edit the viewer applies


def test_a_box_function_writes_its_boxes_and_a_scene_file_rebuilds_it(data, tmp_path):
    """The saved scene's [transfer_function] holds boxes_2d and the ranges; the table a scene file makes
    from them is the editor's, bit for bit."""
    from dvr_gl.scene.resolve import load_scene
    from dvr_gl.viewer.tf_editor_2d import BoxTransferFunction2D
    from dvr_gl.viewer.timeline import with_transfer_function

    (tmp_path / "s.toml").write_text('[volume]\ndemo = "shepp-logan"\nsize = 16\n')
    scene = load_scene(tmp_path / "s.toml")
    ed = BoxEditor2D.for_field(scene.field)
    ed.add(0.3, 0.5 * ed.gradient_range[1])
    ed.set_color(0, (1.0, 0.2, 0.1))
    tf = ed.transfer_function
    assert isinstance(tf, BoxTransferFunction2D) and tf.to_table()["boxes_2d"] == ed.boxes
    (tmp_path / "e.toml").write_text(with_transfer_function(scene, 0, tf).to_toml())
    again = load_scene(tmp_path / "e.toml").transfer_function
    np.testing.assert_array_equal(again.table, tf.table)
    assert again.value_range == tf.value_range and again.gradient_range == tf.gradient_range
    reopened = BoxEditor2D.for_field(scene.field, tf)
    assert reopened.boxes == ed.boxes and reopened.value_range == ed.value_range


def test_display_cells_are_the_log_of_summed_bins(data):
    ed = BoxEditor2D(data, (1.0, 1.0, 1.0), bins=(32, 16))
    cells = ed.display_cells((16, 8))
    counts = np.expm1(ed.log_counts).reshape(16, 2, 8, 2).sum(axis=(1, 3))
    np.testing.assert_allclose(cells, np.log1p(counts) / np.log1p(counts).max(), rtol=1e-12)
