"""The example scenes parse, and render (small) where their data is present."""


import numpy as np
import pytest

from conftest import REPO
from dvr_gl.phantoms import demo_scene
from dvr_gl.renderers import render
from dvr_gl.scene.resolve import load_scene, read_scene_dict

EXAMPLES = sorted((REPO / "examples").glob("*.toml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_example_renders(path):
    raw = read_scene_dict(path)
    source = raw["volume"].get("path")
    if source and not (path.parent / source).exists():
        pytest.skip(f"{source} is not present (shared datasets live beside the repository)")
    scene = load_scene(path, {"image.width": 24, "image.height": 24})
    assert render(scene)[..., 3].max() > 0.05


def test_shepp_logan_example_is_the_demo_scene():
    """The example spells out what ``dvr render --demo`` renders: the demo for the default renderer."""
    from dvr_gl.renderers import registry

    default = registry.plugin(registry.default_for("grid"))
    from_demo = load_scene(None, {}, demo_scene("shepp-logan", default))
    from_file = load_scene(REPO / "examples" / "shepp-logan.toml")
    assert from_demo.renderer == from_file.renderer
    np.testing.assert_allclose(from_demo.camera.eye, from_file.camera.eye)
    np.testing.assert_array_equal(from_demo.transfer_function.points, from_file.transfer_function.points)
    np.testing.assert_array_equal(getattr(from_demo.transfer_function, "table", None),
                                  getattr(from_file.transfer_function, "table", None))
