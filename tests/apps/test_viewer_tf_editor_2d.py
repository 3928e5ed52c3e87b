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
