"""Every regular-grid dataset in ../shared/data renders sensibly with every renderer that bricks a grid
(it declares a texture budget), against its own oracle (the same-discretization reference: same samples
or same planes), the CT bunny through bricks under a small texture budget.  Shader filtering keeps uint8
data exact (see the ray caster's tests), so the tolerance is the float32 one.  Renderers with judges of
their own shape test the same datasets in their folders (``test_datasets_NAME.py``)."""

import numpy as np
import pytest

from conftest import assert_close
from dvr_gl.renderers import create_renderer, registry
from dvr_gl.scene.resolve import load_scene
from judges import renderers as declaring
from rendered_datasets import DATASETS, dataset_id, judged

BRICKING = declaring("texture_budget_mb", gl=True)


@pytest.fixture(scope="module")
def renderers(shared_gl_context):
    made = {name: create_renderer(name, ctx=shared_gl_context) for name in BRICKING}
    yield made
    for r in made.values():
        r.close()


@pytest.fixture(scope="module")
def dataset_scenes(shared_data):
    """``scene(name)``: the dataset's scene, read once for every renderer (the last one kept: the CT bunny
    is large); the tests run a dataset's renderers one after another."""
    kept = {}

    def scene(name):
        if name not in kept:
            kept.clear()
            kept[name] = load_scene(None, {"volume.path": str(shared_data / name), "image.width": 24,
                                           "image.height": 24, "renderer.filtering": "shader",
                                           "renderer.ert_threshold": 1.0, "renderer.sample_distance_voxels": 1.0,
                                           **DATASETS[name]})
        return kept[name]
    return scene


@pytest.mark.parametrize("renderer", BRICKING)  # the first decorator's parameter varies fastest
@pytest.mark.parametrize("name", list(DATASETS), ids=dataset_id)
def test_dataset_renders(dataset_scenes, renderers, name, renderer):
    scene = dataset_scenes(name)
    image = renderers[renderer].render(scene)
    # the judge is called directly, so it gets the camera in the volume's own frame as Renderer.render
    # gives it to the renderers (MNI152's sform: RAS, a mirrored view flipped back; dvr_gl.orientation)
    reference = judged(registry.plugin(renderer).oracle_image, scene)
    assert np.all(np.isfinite(image)) and image.min() >= 0 and image[..., 3].max() <= 1
    assert reference[..., 3].max() > 0.05, "the preset shows nothing of this dataset"
    assert_close(image, reference)
    if "bunny" in name:
        assert renderers[renderer].stats["bricks"] > 1
