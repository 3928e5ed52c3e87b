"""Shear-warp's clipping: samples outside the region dropped on the host, against the
plane oracle (``PLUGIN.oracle``, the same planes) and the Beer-Lambert closed form on the slab."""

from __future__ import annotations

import pytest

from slab_scenes import CASES, PLANE_EXTRAS, clip_phantom_as_its_planes, clip_slab_as_its_planes

# shear-warp does not pre-integrate
EXTRAS = {k: v for k, v in PLANE_EXTRAS.items() if k != "preintegrated"}


@pytest.mark.parametrize("case", CASES)
def test_shearwarp_clips_the_slab_as_its_planes(tmp_path, gl_context, case):
    """Against its same planes, and within ``S s`` of Beer-Lambert with ``s`` the voxel spacing 0.5."""
    clip_slab_as_its_planes(gl_context, tmp_path, "shearwarp", case, spacing=0.5)  # it clips on the host: no define


@pytest.mark.parametrize("extra", list(EXTRAS.values()), ids=list(EXTRAS))
def test_shearwarp_drops_what_is_clipped_as_its_planes(gl_context, extra):
    clip_phantom_as_its_planes(gl_context, "shearwarp", extra)
