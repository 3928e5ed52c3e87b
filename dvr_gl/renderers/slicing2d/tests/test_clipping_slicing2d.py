"""2D texture slicing's clipping: fragments outside the region discarded, against the
plane oracle (``PLUGIN.oracle``, the same planes) and the Beer-Lambert closed form on the slab."""

from __future__ import annotations

import pytest

from slab_scenes import CASES, PLANE_EXTRAS, clip_phantom_as_its_planes, clip_slab_as_its_planes

EXTRAS = PLANE_EXTRAS


@pytest.mark.parametrize("case", CASES)
def test_slicing2d_clips_the_slab_as_its_planes(tmp_path, gl_context, case):
    """Against its same planes, and within ``S s`` of Beer-Lambert with ``s`` the voxel spacing 0.5."""
    defines = clip_slab_as_its_planes(gl_context, tmp_path, "slicing2d", case, spacing=0.5)
    assert defines["CLIPPING"]


@pytest.mark.parametrize("extra", list(EXTRAS.values()), ids=list(EXTRAS))
def test_slicing2d_drops_what_is_clipped_as_its_planes(gl_context, extra):
    clip_phantom_as_its_planes(gl_context, "slicing2d", extra)
