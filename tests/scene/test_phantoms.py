"""The built-in phantoms: the Shepp-Logan phantom equal to its definition, node by node, and the demo
scene's picture."""

import math

import numpy as np
import pytest

from dvr_gl.phantoms import SHEPP_LOGAN_3D, demo_scene, gaussian_blur, shepp_logan


def shepp_logan_by_definition(n: int, subsamples: int, blur: float) -> np.ndarray:
    """Every ellipsoid tested at every sub-sample of every node (the phantom as first written, 20x
    slower at 96^3): ``shepp_logan`` tests each only near its bounding box and must give the same
    numbers, bit for bit."""
    step = 2.0 / (n - 1)
    axis = -1.0 + step * np.arange(n)
    out = np.zeros((n, n, n))
    sub = (np.arange(subsamples) + 0.5) / subsamples - 0.5
    for ox in sub:
        for oy in sub:
            for oz in sub:
                z, y, x = np.meshgrid(axis + oz * step, axis + oy * step, axis + ox * step, indexing="ij")
                for A, a, b, c, x0, y0, z0, phi in SHEPP_LOGAN_3D:
                    cp, sp = math.cos(math.radians(phi)), math.sin(math.radians(phi))
                    xr = (x - x0) * cp + (y - y0) * sp
                    yr = -(x - x0) * sp + (y - y0) * cp
                    out[(xr / a) ** 2 + (yr / b) ** 2 + ((z - z0) / c) ** 2 <= 1.0] += A
    out = gaussian_blur(out / subsamples ** 3, blur) if blur > 0 else out / subsamples ** 3
    return np.clip(out, 0.0, 1.0).astype(np.float32)


@pytest.mark.parametrize("n, subsamples, blur", [(24, 3, 0.75), (33, 2, 0.75), (40, 1, 0.0), (17, 3, 0.0)])
def test_shepp_logan_equals_its_definition(n, subsamples, blur):
    np.testing.assert_array_equal(shepp_logan(n, subsamples, blur), shepp_logan_by_definition(n, subsamples, blur))


def test_shepp_logan_values_are_the_modified_densities():
    """Unblurred, one sample per node: the nodes take sums of the modified phantom's densities (skull 1,
    brain 0.2, ventricles 0, lesions 0.3, 0.1 where one reaches into a ventricle, 0.4 where two overlap)
    and nothing else; float64 sums of the densities, so within 1e-6."""
    data = shepp_logan(65, subsamples=1, blur=0.0)
    values = {round(float(v), 6) for v in np.unique(data)}
    assert values <= {0.0, 0.1, 0.2, 0.3, 0.4, 1.0}
    assert {0.0, 0.2, 0.3, 1.0} <= values
    assert data[32, 32, 32] == pytest.approx(0.2)     # the centre is brain
    assert data[32, 32, 0] == 0.0                     # x = -1: outside the head


@pytest.fixture(scope="module")
def demo_picture():
    """The default renderer's demo at its size (96^3; the skull's thickness and the gradients it is tuned to are
    the phantom's at that size), on 96x96 pixels: (RGBA, the premultiplied colour's red minus blue over alpha)."""
    from dvr_gl.renderers import registry, render
    from dvr_gl.scene.resolve import load_scene

    scene = load_scene(None, {"image.width": 96, "image.height": 96},
                       demo_scene("shepp-logan", registry.plugin(registry.default_for("grid"))))
    rgba = render(scene)
    warm = (rgba[..., 0] - rgba[..., 2]) / np.maximum(rgba[..., 3], 1e-6)
    return rgba, warm


def test_the_demo_is_bright(demo_picture):
    """The demo is coloured: its image's mean linear RGB is above 0.05 (the demo before issue 21: 0.008; issue
    43's unshaded one: 0.018 at 48^3; now 0.11), a half-opaque pixel (alpha above 0.5) shows the orange lesion
    (red above blue by more than 0.25; now 0.36: it lies behind the brain) and one the blue brain (blue above
    red by more than 0.5; now 0.68)."""
    rgba, warm = demo_picture
    assert rgba[..., :3].mean() > 0.05
    seen = rgba[..., 3] > 0.5
    assert warm[seen].max() > 0.25
    assert -warm[seen].min() > 0.5


def test_the_demo_has_no_rim(demo_picture):
    """No orange line along the skull's rim: within 6 pixels of the head's silhouette (alpha above 0.05) no pixel
    is warmer than the ivory skull (red above blue by 0.15); measured 0.11, and 0.79 with the lesions' band
    classified by value alone (the skull's soft inner edge crosses the lesions' values: dvr_gl/phantoms.py)."""
    from scipy import ndimage

    rgba, warm = demo_picture
    head = rgba[..., 3] > 0.05
    rim = head & ~ndimage.binary_erosion(head, iterations=6)
    assert rim.sum() > 500
    assert warm[rim].max() < 0.2


def test_the_demo_has_no_blue_outline(demo_picture):
    """The head's outermost two pixels (alpha above 0.01) are the ivory skull's colour (red above blue by 0.15
    over alpha), not the brain's blue (-0.7): the skull's outer soft edge passes the brain's values at high
    gradient, where the demo's 2D table has no brain (dvr_gl/phantoms.py, BRAIN_GRADIENT).  Measured: 0.142 at
    least; with the brain's band at every gradient, -0.7 on most of that ring."""
    from scipy import ndimage

    rgba, warm = demo_picture
    head = rgba[..., 3] > 0.01
    outline = head & ~ndimage.binary_erosion(head, iterations=2)
    assert outline.sum() > 200
    assert warm[outline].min() > 0.1


def test_the_demo_keeps_to_each_renderer():
    """``demo_scene`` with a renderer's declaration gives a scene that renderer does not refuse: every grid
    renderer, each demo (the projection-only renderers get an orthographic X-ray; kernels, classifications
    and filters the renderer takes; shading and scattering off where it has none)."""
    from dvr_gl.phantoms import DEMOS, PARTICLE_DEMOS
    from dvr_gl.renderers import registry
    from dvr_gl.scene.resolve import load_scene

    for name, plugin in registry.plugins().items():
        kinds = plugin.data_kinds or ("grid",)
        for demo in DEMOS:
            if ("particles" if demo in PARTICLE_DEMOS else "grid") not in kinds:
                continue
            scene = load_scene(None, {"volume.size": 8, "renderer.name": name}, demo_scene(demo, plugin))
            assert registry.refusal(scene) is None, (name, demo)
