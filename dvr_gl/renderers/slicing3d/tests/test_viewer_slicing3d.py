"""The viewer's words for view-aligned slicing (from tests/apps/test_viewer.py): its sample distance is a
slice spacing, with the number of slices."""

from conftest import small_scene
from dvr_gl.viewer import settings


def test_the_viewer_tells_the_slice_spacing_and_count():
    text = settings.sampling_text(settings.change(small_scene(), name="slicing3d"))
    assert "slices" in text and text.startswith("slice spacing")
