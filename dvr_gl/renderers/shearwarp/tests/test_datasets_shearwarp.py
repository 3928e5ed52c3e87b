"""Every regular-grid dataset in ../shared/data rendered by shear-warp against its same-discretization
reference (from tests/apps/test_datasets_render.py): parallel and perspective, shaded, and from inside."""

import numpy as np
import pytest

from conftest import assert_close
from dvr_gl.orientation import to_patient_frame
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.shearwarp.oracle import oracle as shearwarp_reference
from rendered_datasets import DATASETS, dataset_id, judged


@pytest.fixture(scope="module")
def renderer(shared_gl_context):
    made = create_renderer("shearwarp", ctx=shared_gl_context)
    yield made
    made.close()


@pytest.mark.parametrize("name", list(DATASETS), ids=dataset_id, scope="module")
def test_dataset_renders_with_shear_warp(renderer, shared_scene, name):
    """Parallel and perspective against shear-warp's same-discretization reference (the same slices
    along the intermediate pixels' rays, warped bilinearly): measured max 3.1e-5 (the bunny,
    orthographic), mean <= 2.5e-7; asserted as for the other renderers."""
    overrides = {"image.width": 24, "image.height": 24, "renderer.ert_threshold": 1.0, **DATASETS[name]}
    tf = None
    for projection in ("perspective", "orthographic"):
        scene = shared_scene(name, {**overrides, "camera.projection": projection})
        # the first scene's transfer function object (the same points): the renderer keys its run-length
        # encoding on it, so the second view reuses the encoding (the bunny's takes seconds) as a viewer would
        tf = scene.transfer_function if tf is None else tf
        scene = scene.replace(transfer_function=tf)
        image = renderer.render(scene)
        reference = judged(shearwarp_reference, scene)
        assert np.all(np.isfinite(image)) and image.min() >= 0 and image[..., 3].max() <= 1
        assert reference[..., 3].max() > 0.05, "the preset shows nothing of this dataset"
        assert_close(image, reference)


@pytest.mark.parametrize("name", list(DATASETS), ids=dataset_id, scope="module")
def test_dataset_renders_with_shaded_shear_warp(renderer, shared_scene, name):
    """Shaded by the lookup tables over quantized normals (the headlight, perspective), against the same
    slices shaded alike in float64: measured max 2.4e-5 (headsq), mean <= 2.1e-7, every value within
    1e-4 on all twelve; asserted as for the other renderers."""
    overrides = {"image.width": 24, "image.height": 24, "renderer.ert_threshold": 1.0,
                 "renderer.shading.enabled": True, **DATASETS[name]}
    scene = shared_scene(name, overrides)
    image = renderer.render(scene)
    reference = judged(shearwarp_reference, scene)
    assert reference[..., 3].max() > 0.05 and np.all(np.isfinite(image))
    assert_close(image, reference)


@pytest.mark.parametrize("name", [n for n in DATASETS if n.startswith("regular/")],
                         ids=dataset_id, scope="module")
def test_dataset_renders_with_shear_warp_from_inside(renderer, shared_scene, name):
    """The eye near the volume's centre, a 100-degree view along a diagonal, shaded: the view factored
    by pyramids of rays (three or four here), against the same slices of each pyramid shaded alike in
    float64, warped: measured max 2.4e-6 (headsq), mean <= 1e-7; asserted as for the other renderers.
    The two large datasets (frog 1.2e-6, bunny 2.1e-6) take 20 and 60 s with their references, so they
    are measured, not run here."""
    scene = shared_scene(name, {"image.width": 24, "image.height": 24, "renderer.ert_threshold": 1.0,
                                "renderer.shading.enabled": True, **DATASETS[name]})
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.volume.box)
    eye = (lo + hi) / 2.0 + 0.013 * (hi - lo)  # off the centre: no slice plane through the eye
    # placed in the volume's frame, given in the patient frame where the camera lives (dvr_gl.orientation)
    eye_p, target_p = to_patient_frame(scene.volume, [eye, eye + (hi - lo) * [0.7, 1.0, 0.4]])
    scene = scene.replace(camera=scene.camera.with_(eye=tuple(eye_p), target=tuple(target_p), fov=100.0))
    image = renderer.render(scene)
    assert renderer.stats["factorizations"] >= 2
    reference = judged(shearwarp_reference, scene)
    assert reference[..., 3].max() > 0.05 and np.all(np.isfinite(image))
    assert_close(image, reference)
