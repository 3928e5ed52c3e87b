"""2D texture slicing (stacks of the voxel planes along the axis nearest the view) against the reference
that samples the same planes, and its behaviour (the checks every slicer passes: tests/slice_checks.py)."""

import pytest

import slice_checks as checks
from conftest import small_scene
from dvr_gl.errors import SceneError


@pytest.fixture(scope="module")
def slicer(shared_gl_context):
    renderer = checks.slicer_on(shared_gl_context, "slicing2d")
    yield renderer
    renderer.close()


@pytest.fixture(autouse=True)
def current_context(gl_context):
    """The session's context current for every test (a renderer released elsewhere leaves none)."""
    return gl_context


@pytest.mark.parametrize("extra", checks.VARIANTS, ids=checks.VARIANT_IDS)
def test_slicing2d_matches_the_same_plane_reference(slicer, extra):
    checks.matches_the_same_plane_reference(slicer, extra)


@pytest.mark.parametrize("extra, message", checks.REFUSALS)
def test_slicing2d_refuses_other_compositing_and_jitter(slicer, extra, message):
    checks.refuses(slicer, extra, message)


@pytest.mark.parametrize("extra", list(checks.BRICKED.values()), ids=list(checks.BRICKED))
def test_slicing2d_bricked_equals_unbricked(slicer, extra):
    checks.bricked_equals_unbricked(slicer, extra)


def test_slicing2d_one_voxel_thick_volume(tmp_path, slicer):
    checks.one_voxel_thick_volume(tmp_path, slicer)


@pytest.mark.parametrize("extra", [{"renderer.filter": "cubic_bspline"}, {"renderer.classification": "pre"},
                                   {"renderer.shading.enabled": True, "renderer.gradient": "texture"}])
def test_slicing2d_refuses_what_stacks_cannot_do(slicer, extra):
    with pytest.raises(SceneError, match="slicing2d"):
        slicer.render(small_scene(extra))
