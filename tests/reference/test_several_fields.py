"""Both references on several fields (dvr_gl/reference/fields.py) against closed forms and each other.

The mixture (docs/several-fields.md): inside member i's box it adds ``sigma_i`` and ``sigma_i c_i``; the closed
forms below are exact for fields constant or linear inside their boxes.  Every view is oblique (chords of
every length, box faces crossed at every angle)."""

from __future__ import annotations

import numpy as np
import pytest

from dvr_gl.api import scene_of
from dvr_gl.errors import SceneError
from dvr_gl.fields.grid import Volume
from dvr_gl.fields.layers import FieldSet, Member
from dvr_gl.rays import intersect_box
from dvr_gl.reference.converged import ConvergedReference
from dvr_gl.reference.discrete import DiscreteReference
from dvr_gl.reference.model import OpticalModel
from dvr_gl.transfer_function import TransferFunction
from judges import CONVERGED, DISCRETE

SIZE = (16, 14)
VIEW = {"azimuth": 23.0, "elevation": 17.0, "projection": "perspective", "fov": 40.0}
NO_ERT = {"ert_threshold": 1.0}
RED, GREEN = (0.9, 0.1, 0.0), (0.0, 0.8, 0.3)


def constant_tf(colour, alpha) -> TransferFunction:
    return TransferFunction([[0.0, *colour, alpha], [1.0, *colour, alpha]])


def ramp_tf(colour, alpha) -> TransferFunction:
    return TransferFunction([[0.0, *colour, 0.0], [1.0, *colour, alpha]])


def box_volume(shape=(8, 8, 8), value=0.5, origin=(0.0, 0.0, 0.0), spacing=(1.0, 1.0, 1.0)) -> Volume:
    return Volume(np.full(shape, value, np.float32), spacing=spacing, origin=origin)


def scene(volumes, tfs, judge, **settings):
    return scene_of(list(volumes), transfer_function=list(tfs), renderer=judge, size=SIZE, **{**VIEW, **settings})


def render(judge, s):
    return (DiscreteReference if judge == DISCRETE else ConvergedReference)(s).render_float64()


def chords(s, boxes, maps=None):
    """Per pixel ray: its parameter interval ``(a, b)`` in each box (``b <= a``: none), and the ray's speed;
    ``maps``: per box None or ``(A, b)``, the box being axis-aligned in the frame ``q = A p + b`` (rigid)."""
    ref = DiscreteReference(s)
    r = ref.rays
    out = []
    for (lo, hi), m in zip(boxes, maps or [None] * len(boxes)):
        o, d = (r.origins, r.directions) if m is None else (r.origins @ m[0].T + m[1], r.directions @ m[0].T)
        a, b = intersect_box(o, d, lo, hi)
        out.append((np.maximum(a, r.t0), np.minimum(b, r.t1)))
    return out, np.linalg.norm(r.directions, axis=1)


def composited(s, members, maps=None):
    """The exact emission-absorption image of members ``(box, colour, sigma)`` constant in their boxes: each
    ray cut at every box face into intervals of constant mixture, composited front to back."""
    spans, speed = chords(s, [m[0] for m in members], maps)
    n = len(speed)
    rgba = np.zeros((n, 4))
    for ray in range(n):
        cuts = sorted({t for a, b in spans for t in (a[ray], b[ray]) if b[ray] > a[ray]})
        tau = 0.0
        for t_a, t_b in zip(cuts[:-1], cuts[1:]):
            mid = 0.5 * (t_a + t_b)
            inside = [i for i, (a, b) in enumerate(spans) if a[ray] <= mid <= b[ray]]
            sigma = sum(members[i][2] for i in inside)
            if sigma == 0:
                continue
            colour = sum(members[i][2] * np.asarray(members[i][1]) for i in inside) / sigma
            step = sigma * (t_b - t_a) * speed[ray]
            rgba[ray, :3] += np.exp(-tau) * -np.expm1(-step) * colour
            tau += step
        rgba[ray, 3] = -np.expm1(-tau)
    return rgba.reshape(SIZE[1], SIZE[0], 4)


def sigma_of(tf, value=0.5) -> float:
    return float(tf.evaluate(np.array([value]))[1][0])


@pytest.mark.parametrize("judge, classification", [(DISCRETE, "post"), (DISCRETE, "preintegrated"), (DISCRETE, "pre"),
                                                    (CONVERGED, "post"), (CONVERGED, "pre")])
def test_two_overlapping_constant_channels(judge, classification):
    """Transmittance ``exp(-(s1 + s2) L)``, colour ``(s1 c1 + s2 c2) / (s1 + s2)`` times the opacity.  Measured
    error: 3e-16 (discrete: post, pre-classified, pre-integrated by the mixture rule), 6e-11 (converged, its
    default tolerance, post and pre-classified): asserted 1e-9."""
    tfs = [constant_tf(RED, 0.3), constant_tf(GREEN, 0.6)]
    s = scene([box_volume(), box_volume()], tfs, judge, classification=classification, **NO_ERT)
    image = render(judge, s)
    lo, hi = s.field.bounds
    exact = composited(s, [((lo, hi), RED, sigma_of(tfs[0])), ((lo, hi), GREEN, sigma_of(tfs[1]))])
    assert exact[..., 3].max() > 0.9 and (exact[..., 3] == 0).any()
    np.testing.assert_allclose(image, exact, rtol=0, atol=1e-9)


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_xray_of_two_channels(judge):
    """The X-ray sums ``sigma len`` and ``sigma c len`` of both: alpha ``1 - exp(-(s1 + s2) L)``, the same
    extinction-weighted colour.  Measured 3e-16 (both); asserted 1e-9."""
    tfs = [constant_tf(RED, 0.3), constant_tf(GREEN, 0.6)]
    s = scene([box_volume(), box_volume()], tfs, judge, compositing="xray")
    lo, hi = s.field.bounds
    exact = composited(s, [((lo, hi), RED, sigma_of(tfs[0])), ((lo, hi), GREEN, sigma_of(tfs[1]))])
    np.testing.assert_allclose(render(judge, s), exact, rtol=0, atol=1e-9)


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_members_contribute_only_inside_their_boxes(judge):
    """Two grids overlapping in part (different dims, spacing, origin): the exact image cuts each ray at the
    four faces it crosses.  The converged reference cuts there too: measured 1.1e-12.  The discrete reference's
    segments that straddle a face count whole or not at all: at most ``sigma d`` per face (sigma <= 0.92,
    d = 0.05: 0.046 per face), measured 0.0059 at worst, 1.0e-4 on average; asserted 0.02 and 5e-4."""
    a = box_volume((8, 8, 8))
    b = box_volume((5, 6, 7), origin=(3.0, 2.5, 4.0), spacing=(1.25, 1.0, 0.75))
    tfs = [constant_tf(RED, 0.3), constant_tf(GREEN, 0.6)]
    s = scene([a, b], tfs, judge, sample_distance=0.05, **NO_ERT)
    exact = composited(s, [(a.box, RED, sigma_of(tfs[0])), (b.box, GREEN, sigma_of(tfs[1]))])
    err = np.abs(render(judge, s) - exact)
    if judge == CONVERGED:
        assert err.max() < 1e-9
    else:
        assert err.max() < 0.02 and err.mean() < 5e-4


def test_an_oriented_member_contributes_inside_its_oriented_box():
    """A second grid turned 30 degrees about z and 20 about x (its own direction matrix): the converged reference
    cuts each ray where it crosses that oriented box's faces (the ray mapped into its frame), as the exact image
    does: measured 1.1e-12; asserted 1e-9.  Its union box is the oriented box's bounding box."""
    a, b = np.radians(30.0), np.radians(20.0)
    about_z = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    about_x = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    first = box_volume((8, 8, 8))
    turned = Volume(np.full((5, 6, 7), 0.5, np.float32), spacing=(1.25, 1.0, 0.75), origin=(3.0, 2.5, 1.0),
                    direction=about_z @ about_x)
    tfs = [constant_tf(RED, 0.3), constant_tf(GREEN, 0.6)]
    s = scene([first, turned], tfs, CONVERGED, **NO_ERT)
    maps = list(s.field.transforms)
    assert maps[0] is None and maps[1] is not None
    exact = composited(s, [(first.box, RED, sigma_of(tfs[0])), (turned.box, GREEN, sigma_of(tfs[1]))], maps)
    assert exact[..., 3].max() > 0.5
    err = np.abs(render(CONVERGED, s) - exact)
    assert err.max() < 1e-9, f"max error {err.max():.3g}"


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_a_channel_behind_an_opaque_one_adds_nothing(judge):
    """A green box behind an opaque red one (sigma L >= 40 through it): where a ray crosses the red box whole
    and then the green one, the image is the red box's alone (exp(-40) = 4e-18)."""
    front = box_volume((8, 8, 8))
    behind = box_volume((8, 8, 8), origin=(0.0, 9.0, 0.0))  # along the view (+y at azimuth 0)
    tfs = [constant_tf(RED, 0.99999), constant_tf(GREEN, 0.6)]
    view = {"azimuth": 0.0, "elevation": 0.0, "projection": "orthographic"}
    both = render(judge, scene([front, behind], tfs, judge, **view, **NO_ERT))
    alone = render(judge, scene([front, box_volume((1, 1, 1), 0.0, origin=(0.0, 9.0, 0.0))],
                                [tfs[0], constant_tf(GREEN, 0.0)], judge, **view, **NO_ERT))
    crossing = both[..., 3] > 1.0 - 1e-12
    assert crossing.sum() > 8
    np.testing.assert_allclose(both[crossing], alone[crossing], rtol=0, atol=1e-12)
    assert both[crossing][:, 2].max() < 1e-12  # no trace of the green box's blue


def ramp(axis: int, shape=(8, 8, 8)) -> Volume:
    """Values ``u / (n - 1)`` along ``axis`` (0 = x): 0 to 1 across the box."""
    n = shape[2 - axis]
    values = np.arange(n, dtype=np.float64) / (n - 1)
    data = np.broadcast_to(values.reshape([-1 if a == 2 - axis else 1 for a in range(3)]), shape)
    return Volume(np.ascontiguousarray(data, np.float32))


@pytest.mark.parametrize("mode", ["mip", "minip", "average"])
@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_per_channel_projections_of_two_ramps(judge, mode):
    """A ramp along x (red) and one along y (green) on one grid: each channel's MIP (MinIP) is its larger
    (smaller) end of the chord, its average the mean of the ends; each classified by its own transfer function
    (opacity of one unit distance), added: ``rgb = sum a_i c_i``, ``alpha = 1 - prod (1 - a_i)``.  Converged:
    measured 2e-8, the float32 rounding of the ramp's samples (asserted 1e-7).  Discrete (d = 0.05, a 4096-entry
    table): the extreme sample lies up to half a segment inside the chord's end: measured 0.0027 (MIP), 0.0029
    (MinIP), asserted 0.006; the average's midpoint rule is exact for a linear field: measured 2.4e-8,
    asserted 1e-7."""
    tfs = [ramp_tf(RED, 0.8), ramp_tf(GREEN, 0.5)]
    s = scene([ramp(0), ramp(1)], tfs, judge, compositing=mode, sample_distance=0.05, lut_size=4096)
    ((a, b),), speed = chords(s, [s.field.bounds])
    r = DiscreteReference(s).rays
    has = b > a
    ends = [r.origins + t[:, None] * r.directions for t in (a, b)]
    rgba = np.zeros((len(a), 4))
    clear = np.ones(len(a))
    for axis, tf in enumerate(tfs):
        v = np.stack([e[:, axis] / 7.0 for e in ends])
        value = {"mip": v.max(axis=0), "minip": v.min(axis=0), "average": v.mean(axis=0)}[mode][has]
        colour, sigma = tf.evaluate(value)
        alpha = -np.expm1(-sigma * tf.unit_distance)
        rgba[has, :3] += colour * alpha[:, None]
        clear[has] *= 1.0 - alpha
    rgba[:, 3] = 1.0 - clear
    exact = rgba.reshape(SIZE[1], SIZE[0], 4)
    err = np.abs(render(judge, s) - exact)
    assert exact[..., 3].max() > 0.4
    assert err.max() < (1e-7 if judge == CONVERGED or mode == "average" else 0.006)


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_isosurface_first_hit_of_any_member(judge):
    """A ramp along x (iso 0.5: the plane x = 3.5, red) and a box beyond it (green, 0.9 but for its far
    plane, 0.5: its iso-value, the middle of its range, 0.7, is reached on its near faces): looking along +x
    the ramp's plane comes first, along -x the box's face.  Unshaded: the hit member's colour at its
    iso-value, opaque."""
    tfs = [constant_tf(RED, 0.5), constant_tf(GREEN, 0.5)]
    data = np.full((8, 8, 4), 0.9, np.float32)
    data[:, :, 0] = 0.5
    box = Volume(data, origin=(9.0, 0.0, 0.0))
    for azimuth, colour in ((-90.0, RED), (90.0, GREEN)):
        s = scene([ramp(0), box], tfs, judge, compositing="isosurface", iso_value=0.5, azimuth=azimuth,
                  elevation=0.0, projection="orthographic")
        assert [layer.iso_value for layer in s.layers] == [0.5, pytest.approx(0.7)]
        image = render(judge, s)
        hit = image[..., 3] == 1.0
        both = chords(s, [Volume(np.zeros((8, 8, 8), np.float32)).box, box.box])[0]
        through = ((both[0][1] > both[0][0]) & (both[1][1] > both[1][0])).reshape(SIZE[1], SIZE[0])
        assert through.sum() > 4 and hit[through].all()
        np.testing.assert_allclose(image[through][:, :3], np.broadcast_to(colour, (through.sum(), 3)), atol=1e-12)


def test_both_references_agree_as_the_step_shrinks():
    """Two smooth random channels on different grids, shaded: the discrete reference approaches the converged
    one as the step shrinks; segments straddling a box face make the error O(d) there (measured RMS ratios
    per 4x smaller step: 3.9 and 4.7; asserted > 3)."""
    rng = np.random.default_rng(5)
    a = Volume(rng.random((6, 7, 8)).astype(np.float32))
    b = Volume(rng.random((5, 5, 5)).astype(np.float32), spacing=(1.5, 1.2, 1.0), origin=(2.0, 1.0, 0.5))
    tfs = [ramp_tf(RED, 0.7), TransferFunction([[0.0, *GREEN, 0.0], [0.4, *GREEN, 0.9], [1.0, *RED, 0.2]])]
    base = {"shading": True, "lut_size": 1 << 16, **NO_ERT}
    converged = render(CONVERGED, scene([a, b], tfs, CONVERGED, converged_tolerance=1e-7, shading=True))
    errors = [np.sqrt(np.mean((render(DISCRETE, scene([a, b], tfs, DISCRETE, sample_distance=d, **base))
                               - converged) ** 2)) for d in (0.4, 0.1, 0.025)]
    assert errors[0] > 3 * errors[1] > 9 * errors[2]


def test_one_member_mixes_as_the_single_field_model():
    """A FieldSet of one scalar member (the mixture of one) renders as that field alone (the single-field
    path, which a plain grid always takes: its model is the single-field one) to float64 rounding."""
    rng = np.random.default_rng(2)
    v = Volume(rng.random((6, 6, 6)).astype(np.float32))
    tf = ramp_tf(RED, 0.7)
    for judge in (DISCRETE, CONVERGED):
        for mode in ("emission_absorption", "mip", "isosurface"):
            single = scene_of(v, transfer_function=tf, renderer=judge, size=SIZE, compositing=mode, shading=True,
                              **VIEW)
            ref = (DiscreteReference if judge == DISCRETE else ConvergedReference)(single)
            assert type(ref.model) is OpticalModel
            one = single.replace(field=FieldSet([Member(v)]), camera=single.camera)
            one = one.replace(transfer_function=tf)
            np.testing.assert_allclose(render(judge, one), ref.render_float64(), rtol=0, atol=1e-12)


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_what_the_mixture_does_not_define_is_refused_in_one_line(judge):
    from dvr_gl.labels import LabelTable

    tfs = [constant_tf(RED, 0.3), constant_tf(GREEN, 0.6)]
    with pytest.raises(SceneError, match="scattering") as refused:
        render(judge, scene([box_volume(), box_volume()], tfs, judge, scattering=True))
    assert "\n" not in str(refused.value)
    labels = Member(slab_labels(), "label")
    with pytest.raises(SceneError, match="label field has no value to project") as refused:
        render(judge, scene([box_volume(), labels], [tfs[0], LabelTable.from_rows([[3, *RED, 0.5]])], judge,
                            compositing="mip"))
    assert "\n" not in str(refused.value)
    if judge == CONVERGED:  # the X-ray's hemispherical shading (a converged reference's option)
        with pytest.raises(SceneError, match="hemispherical shading"):
            render(judge, scene([box_volume(), labels], [tfs[0], LabelTable.from_rows([[3, *RED, 0.5]])], judge,
                                compositing="xray", hemispherical_shading=True))


def test_back_to_front_equals_front_to_back_on_several_fields():
    """The over operator from the last segment equals front-to-back compositing on a scalar channel, a label map
    and a colour volume on three grids, shaded with gradient opacity (float64 rounding: measured 3e-16)."""
    from dvr_gl.fields.color import ColorVolume
    from dvr_gl.labels import LabelTable

    rng = np.random.default_rng(7)
    scalar = Volume(rng.random((6, 7, 8)).astype(np.float32))
    rgb = ColorVolume.from_linear(rng.random((5, 5, 5, 4)).astype(np.float32), origin=(1.0, 2.0, 0.5))
    table = LabelTable.from_rows([[3, *RED, 0.5]])
    tfs = [ramp_tf(GREEN, 0.7), table, ramp_tf((1, 1, 1), 0.6)]
    data = [scalar, Member(slab_labels(), "label"), Member(rgb, "rgb")]
    common = {"shading": True, "gradient_opacity": True, **NO_ERT}
    front = render(DISCRETE, scene(data, tfs, DISCRETE, **common))
    back = render(DISCRETE, scene(data, tfs, DISCRETE, order="back_to_front", **common))
    assert front[..., 3].max() > 0.5
    np.testing.assert_allclose(back, front, rtol=0, atol=1e-12)


def slab_labels(label=3, lo=2, hi=5, shape=(8, 8, 8)) -> Volume:
    """Label ``label`` in the voxel columns ``lo .. hi`` along x, 0 elsewhere: its indicator varies along x alone,
    so the label region is the box ``lo - 0.5 <= x <= hi + 0.5`` exactly (the indicator's 0.5 level)."""
    data = np.zeros(shape, np.uint8)
    data[:, :, lo:hi + 1] = label
    return Volume(data)


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_a_label_slab_beside_a_scalar_channel(judge):
    """A slab of label 3 (red, the table's sigma) inside a constant scalar channel (green): the mixture of two
    boxes, the label's ``1.5 <= x <= 5.5`` (the indicator's 0.5 level).  Converged: the label's boundaries found
    by bisection, measured 1e-11, asserted 1e-9; discrete (d = 0.05): segments straddling a boundary count
    whole, measured 0.0088 at worst, 1.5e-4 on average; asserted 0.02 and 5e-4."""
    from dvr_gl.labels import LabelTable

    table = LabelTable.from_rows([[3, *RED, 0.5]])
    tf = constant_tf(GREEN, 0.3)
    s = scene([box_volume(), Member(slab_labels(), "label")], [tf, table], judge, sample_distance=0.05, **NO_ERT)
    lo, hi = s.field.bounds
    label_box = (np.array([1.5, lo[1], lo[2]]), np.array([5.5, hi[1], hi[2]]))
    exact = composited(s, [((lo, hi), GREEN, sigma_of(tf)), (label_box, RED, float(table.extinction[0]))])
    err = np.abs(render(judge, s) - exact)
    if judge == CONVERGED:
        assert err.max() < 1e-9
    else:
        assert err.max() < 0.02 and err.mean() < 5e-4


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_label_isosurface_shows_only_the_tables_colours(judge):
    """The isosurface of a label map (the first visible label) beside a scalar channel that never reaches its
    iso-value: unshaded, every pixel hit is exactly one of the table's colours (never a blend); label 3 meets
    label 5 inside the map.  Looking along +x the slab's face x = 1.5 is hit: the converged first hit lies on it
    to 1e-9 but in the cells where 3 meets 5 (3 < y < 4), where label 0's indicator wins further in (to x = 5/3
    at y = 3.5, where each of the others holds half of the taps' weight)."""
    from dvr_gl.labels import LabelTable

    data = np.zeros((8, 8, 8), np.uint8)
    data[:, :4, 2:6] = 3
    data[:, 4:, 2:6] = 5
    table = LabelTable.from_rows([[3, *RED, 0.5], [5, *GREEN, 0.5]])
    s = scene([box_volume(value=0.1), Member(Volume(data), "label")], [constant_tf(GREEN, 0.3), table], judge,
              compositing="isosurface", iso_value=0.5, azimuth=-90.0, elevation=0.0, projection="orthographic")
    ref = (DiscreteReference if judge == DISCRETE else ConvergedReference)(s)
    image = ref.render_float64()
    hit = image[..., 3] == 1.0
    assert hit.sum() > 20
    colours = image[hit][:, :3]
    is_red, is_green = (np.all(colours == RED, axis=1), np.all(colours == GREEN, axis=1))
    assert np.all(is_red | is_green) and is_red.any() and is_green.any()
    if judge == CONVERGED:
        rays = np.nonzero(hit.reshape(-1))[0]
        points = ref.rays.origins[rays] + ref.hit_t[rays, None] * ref.rays.directions[rays]
        away = np.abs(points[:, 1] - 3.5) > 0.5 + 1e-9
        assert away.sum() > 20
        np.testing.assert_allclose(points[away, 0], 1.5, atol=1e-9)
        assert np.all(points[~away, 0] <= 5.0 / 3.0 + 1e-9)


@pytest.mark.parametrize("judge, classification", [(DISCRETE, "post"), (DISCRETE, "preintegrated"), (DISCRETE, "pre"),
                                                    (CONVERGED, "post"), (CONVERGED, "pre")])
def test_a_colour_volume_beside_a_scalar_channel(judge, classification):
    """A colour volume of constant linear colour and alpha (opacity from its alpha through its transfer
    function) overlapping a constant scalar channel in part: colour from the data, the mixture of two boxes.
    Converged (post and pre-classified): measured 1.7e-11, asserted 1e-9; discrete, post, pre-classified and
    pre-integrated (its tau from the table of x, the data's colour): segments straddling the colour volume's
    faces count whole, measured 0.0058 at worst, 1.6e-4 on average; asserted 0.02 and 5e-4."""
    from dvr_gl.fields.color import ColorVolume

    colour = tuple(float(np.float32(c)) for c in (0.2, 0.5, 0.9))  # as stored
    rgba = np.broadcast_to(np.array([*colour, 1.0], np.float32), (6, 5, 7, 4))
    rgb = ColorVolume.from_linear(np.ascontiguousarray(rgba), origin=(2.0, 3.0, 1.0), spacing=(1.0, 1.0, 1.25))
    tfs = [constant_tf(RED, 0.3), TransferFunction([[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 0.6]])]
    s = scene([box_volume(), Member(rgb, "rgb")], tfs, judge, classification=classification, sample_distance=0.05,
              **NO_ERT)
    exact = composited(s, [(box_volume().box, RED, sigma_of(tfs[0])), (rgb.box, colour, sigma_of(tfs[1], 1.0))])
    err = np.abs(render(judge, s) - exact)
    if judge == CONVERGED:
        assert err.max() < 1e-9
    else:
        assert err.max() < 0.02 and err.mean() < 5e-4


@pytest.mark.parametrize("judge", [DISCRETE, CONVERGED])
def test_colour_volume_isosurface_is_a_level_of_its_opacity_source(judge):
    """A colour volume of constant colour whose alpha ramps along x (iso 0.5: the plane x = 3.5) beside a scalar
    channel reaching its iso-value (0.5, the middle of its range) only beyond, at x = 6.5: the hit takes the
    data's colour (unshaded: exactly the stored colour), on the plane (converged: measured 1.0e-7 off it, the
    float32 rounding of the alpha samples; asserted 1e-6)."""
    from dvr_gl.fields.color import ColorVolume

    colour = tuple(float(np.float32(c)) for c in (0.2, 0.5, 0.9))
    alpha = np.broadcast_to((np.arange(8) / 7.0)[None, None, :], (8, 8, 8))
    rgba = np.concatenate([np.broadcast_to(np.array(colour), (8, 8, 8, 3)), alpha[..., None]], axis=3)
    rgb = ColorVolume.from_linear(rgba.astype(np.float32))
    far = np.zeros((8, 8, 8), np.float32)
    far[:, :, 7] = 1.0
    scalar = Volume(far)
    tfs = [TransferFunction([[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 0.6]]), constant_tf(GREEN, 0.3)]
    s = scene([Member(rgb, "rgb"), scalar], tfs, judge, compositing="isosurface", iso_value=0.5, azimuth=-90.0,
              elevation=0.0, projection="orthographic")
    ref = (DiscreteReference if judge == DISCRETE else ConvergedReference)(s)
    image = ref.render_float64()
    hit = image[..., 3] == 1.0
    assert hit.sum() > 20
    np.testing.assert_allclose(image[hit][:, :3], np.broadcast_to(colour, (hit.sum(), 3)), rtol=0, atol=1e-12)
    if judge == CONVERGED:
        rays = np.nonzero(hit.reshape(-1))[0]
        x = ref.rays.origins[rays, 0] + ref.hit_t[rays] * ref.rays.directions[rays, 0]
        np.testing.assert_allclose(x, 3.5, atol=1e-6)
