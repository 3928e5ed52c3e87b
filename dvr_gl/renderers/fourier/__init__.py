"""``fourier``: Fourier volume rendering (Malzbender 1993; Totsuka and Levoy 1993).  The volume is
pre-multiplied, zero-padded and transformed once (:mod:`.spectrum`); per view the central slice of
its spectrum across the view direction is interpolated in GL (``shaders/slice.frag``) and
inverse-transformed into the projection (:mod:`.projection`): line integrals, so the ``average`` and the
``xray`` of pre-classified voxels, orthographic only.  See ``dvr_gl/renderers/fourier/README.md``; the renderer
is :mod:`.renderer`, its same-slices reference :mod:`.oracle`.
"""

from __future__ import annotations

from typing import Optional

from ...errors import SceneError
from ...gl.geometry import box_corners
from ...scene import settings as s
from ...scene import sweeps
from ...scene.plugin import RendererPlugin
from .spectrum import INTERPOLATIONS

SLICE_INTERPOLATION = s.Setting("slice_interpolation", str, "kaiser_bessel", "how the central slice is "
                                "interpolated from the spectrum's samples: trilinear, cubic_bspline, windowed_sinc "
                                "(sinc under a Kaiser window) or kaiser_bessel (the Kaiser-Bessel gridding kernel, "
                                "its shape from the padding: the smallest replicas), four taps a side but trilinear's "
                                "two; the volume is pre-multiplied by the reciprocal of each kernel's transform",
                                choices=INTERPOLATIONS, group="fourier")
#: The defaults, six taps at padding 1.25 (issue 44): a spectrum four times smaller than at padding 2 (the
#: transform and its memory; 256^3 in about 1 s a channel), and as accurate as four taps at padding 2 or
#: more on every shared dataset (CThead's X-ray 4.8e-3 against 4.6e-3; the blobs ten times more accurate;
#: four taps at padding 1.25 were 2 to 9 times less accurate, dvr_gl/renderers/fourier/README.md).  The
#: polynomial slice kernels (trilinear, cubic_bspline) want padding 2: their replicas fall with it.
PADDING = s.Setting("padding", float, 1.25, "zero padding of the volume before its transform, a factor per axis "
                    "(ghosting of the replicas falls with it; the spectrum's size and time grow with its cube: "
                    "2 for the trilinear and cubic_bspline slices)", check=s.between(1.0, 8.0), group="fourier")
SLICE_TAPS = s.Setting("slice_taps", int, 6, "samples per axis of the windowed slice kernels (kaiser_bessel, "
                       "windowed_sinc): 6 (216 a slice sample, the Kaiser-Bessel kernel's replicas small enough "
                       "for padding 1.25) or 4 (64: cheaper a view, with padding 2); the trilinear and "
                       "cubic_bspline slices have their own (2 and 4) and do not read it",
                       choices=(4, 6), group="fourier")
SLICE_BANDWIDTH = s.Setting("slice_bandwidth", float, 1.0, "how far the central slice's frequencies reach, in "
                            "multiples of the voxels' Nyquist limit (always at least the pixels'): where pixels are "
                            "wider than voxels the slice is computed on a finer grid and the image is its every K-th "
                            "sample, so the frequencies above the pixels' limit alias into the image as they do in "
                            "point samples (0: the pixels' limit only, the cheapest)", check=s.between(0.0, 8.0),
                            group="fourier")
#: The cheaper settings of issue 44's front (dvr_gl/renderers/fourier/README.md, "The front"): the box's clip by
#: the compensating ghost layer instead of the shell pass, and the slice cut to its low frequencies.
BOX_CLIP = s.Setting("box_clip", str, "exact", "how the rays are clipped at the volume's box: exact (the shell "
                     "pass takes off, per pixel, what the whole lines integrate beyond the box) or ghost_layer "
                     "(a layer on each face that cancels it along the face's normal: exact for rays across a face, "
                     "to first order for oblique ones, and no pass a view); the Gaussian filter and hemispherical "
                     "shading always use the ghost layer", choices=("exact", "ghost_layer"), group="fourier")
SLICE_CUTOFF = s.Setting("slice_cutoff", Optional[float], None, "a low-pass: the slice's frequencies beyond this "
                         "multiple of the voxels' Nyquist limit along the image's rows or columns are left out (not "
                         "drawn: the slice pass's work falls with its square; for smooth data); none: every "
                         "frequency of the slice", check=s.between(0.01, 8.0), group="fourier")


def check(scene):
    """Whole chords: the camera outside the volume.  (``renderer.slice_taps`` is the windowed kernels'; the
    trilinear and cubic B-spline slices have their own taps and do not read it: its default, 6, is not
    refused with them.)"""
    _check_ghosts(scene)
    cam = scene.camera
    forward = cam.basis()[0]
    lo, hi = scene.field.bounds
    if float(((box_corners(lo, hi) - cam.eye) @ forward).min()) <= cam.near:
        raise SceneError("fourier integrates whole chords, and the camera is inside the volume or on its faces: "
                         "move it out (camera.distance), the box in front of its near plane")


def _check_ghosts(scene):
    """The volume with its ghost layers (:func:`.projection.with_ghosts`: as many a face as the filter reaches
    voxels, a Gaussian's 5 kernel widths) in float64 channels, and its copy, against the memory budget
    before anything is built (a kernel_width of 1e6 asked for 10^7 layers a face)."""
    import numpy as np

    from ...sandbox import check_bytes
    from .projection import ghost_layers

    r = scene.renderer
    border = ghost_layers(scene)
    count = (4 if r.compositing == "xray" else 1) * (2 if r.hemispherical_shading else 1)
    volume = float(np.prod([float(n + 2 * border) for n in scene.volume.dims]))
    fix = ("use a smaller renderer.kernel_width (the Gaussian's ghost layers: 5 kernel widths a face) or volume"
           if r.filter == "gaussian" else "use a smaller volume")
    check_bytes(2 * 8 * count * volume, f"fourier's volume with {border} ghost layers a face", fix)


PLUGIN = RendererPlugin(
    name="fourier",
    description="Fourier volume rendering: projections from central slices of the volume's spectrum",
    renderer="dvr_gl.renderers.fourier.renderer:FourierRenderer",
    order=100,
    # the X-ray transforms classified voxels
    settings=(s.COMPOSITING.only("average", "xray"), s.CLASSIFICATION.only("pre"),
              s.FILTER.only("linear", "cubic_bspline", "gaussian"), s.KERNEL_WIDTH, s.DEPTH_CUE,
              s.HEMISPHERICAL_SHADING, SLICE_INTERPOLATION, SLICE_TAPS, PADDING, SLICE_BANDWIDTH, SLICE_CUTOFF,
              BOX_CLIP),
    needs_gl=True,
    projections=("orthographic",),  # the projection-slice theorem: parallel projections
    check=check,
    oracle="dvr_gl.renderers.fourier.oracle:oracle",
    # Against the closed forms (tests/closed_forms.py): the box is exact (the border's constant is taken out
    # and added back per chord: measured 3e-8).  The ramp's borders differ by its whole range and its grid is
    # 6-9 voxels: the box's clip is exact (the shell pass), what is left is the band limit at the ramp's
    # kinks (measured 4.9e-4 average, 1.6e-3 X-ray; 0.117 and 0.186 with the first-order ghost layer that
    # the Gaussian filter and hemispherical shading still use; dvr_gl/renderers/fourier/README.md).
    tolerances={"box": 1e-6, ("ramp", "average"): 1e-3, ("ramp", "xray"): 4e-3},
    sweeps=(sweeps.Family("padding", "renderer.padding", (1.25, 1.5, 2.0, 3.0), (("renderer.compositing", "average"),)),
            sweeps.Family("slice bandwidth", "renderer.slice_bandwidth", (0.0, 1.0, 2.0, 4.0),
                          (("renderer.compositing", "xray"),)),
            sweeps.Family("slice bandwidth, 6 taps", "renderer.slice_bandwidth", (1.0, 2.0, 3.0),
                          (("renderer.compositing", "xray"), ("renderer.slice_taps", 6)))),
    bench="dvr_gl.renderers.fourier.bench:COMMANDS",
)
