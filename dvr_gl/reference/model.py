"""What a point along a ray emits and absorbs: the scene's optical model, in float64.

Shared by the same-discretization and the converged reference; they differ
only in where they evaluate it and how they integrate along the ray.
"""

from __future__ import annotations

import numpy as np

from ..fields import filter_parameters, gradient_epsilon, reconstruct
from ..preintegration import preintegrate, shortened
from ..scene.model import CLASSIFIED_ALONG_RAY
from ..shading import blinn_phong, normals_from_gradient
from ..transfer_function import TransferFunction
from ..transfer_function_2d import check_scene, is_2d, voxel_gradient_magnitudes
from .classification import GradientClassifier, PostClassifier, PreClassifier
from .scattering import SingleScattering


def depth_cue(scene):
    """The depth cue's weight at world points (``renderer.depth_cue``, conventions): 1 at the box's nearest
    view depth (from the near plane on), ``depth_cue`` at its farthest, linear in the depth between."""
    from ..gl.geometry import box_corners

    cam, cue = scene.camera, scene.renderer.depth_cue
    forward = np.asarray(cam.basis()[0], float)
    eye = np.asarray(cam.eye, float)
    depths = (box_corners(*scene.field.bounds) - eye) @ forward
    near, far = max(float(depths.min()), cam.near), float(depths.max())
    span = max(far - near, 1e-300)

    def weight(points: np.ndarray) -> np.ndarray:
        return 1.0 - (1.0 - cue) * np.clip(((points - eye) @ forward - near) / span, 0.0, 1.0)
    return weight


def toward_light(scene) -> np.ndarray:
    """The unit vector toward the first light of ``[renderer.shading]`` (a headlight: toward the eye)."""
    light = scene.renderer.shading.lights[0] if scene.renderer.shading.lights else None
    if light is None or light.type == "headlight":
        return -np.asarray(scene.camera.basis()[0], float)
    d = -np.asarray(light.direction, float)
    return d / np.linalg.norm(d)


#: ``|grad|`` at a grid's samples ``(nz, ny, nx[, C])``: central differences one sample apart along each axis, the
#: border samples repeated beyond the grid (as the clamped taps); shared with the 2D transfer functions' histogram
gradient_magnitudes = voxel_gradient_magnitudes


class HemisphericalShading:
    """Totsuka and Levoy's shading of what a line integral adds up (``renderer.hemispherical_shading``):
    ``ambient E + diffuse h (G + grad E . L) / 2``, ``E`` the reconstructed field (the average's scalar,
    the X-ray's emission ``sigma c``), ``G`` the samples' gradient magnitudes (central differences)
    reconstructed by the same filter, ``grad`` the central differences of the reconstructed field one
    sample apart along each axis (as :meth:`SampledField.gradient`), ``L`` toward the light, ``h`` the
    smallest spacing (so the terms keep the value's units): linear in the samples, so that a renderer
    working in the frequency domain can take it there."""

    def __init__(self, scene, field, samples: np.ndarray):
        from ..fields.reconstruction import SampledField

        r, vol = scene.renderer, scene.field
        self.ambient, self.diffuse = r.shading.ambient, r.shading.diffuse
        self.light = toward_light(scene)
        self.spacing = np.asarray(vol.spacing, float)
        self.h = float(self.spacing.min())
        self.field = field  # E: a field of C channels (sample -> (N, C))
        magnitudes = gradient_magnitudes(samples, vol.spacing)
        self.magnitude = SampledField(magnitudes, vol.spacing, vol.origin, r.filter, r.kernel_width, r.kernel_radius)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        e = self.field(points)
        slope = np.zeros_like(e)
        for a in range(3):
            if self.light[a] != 0.0:
                step = np.zeros(3)
                step[a] = self.spacing[a]
                slope += self.light[a] * (self.field(points + step) - self.field(points - step)) / (2.0 * step[a])
        g = self.magnitude.sample(points).reshape(e.shape)
        return self.ambient * e + self.diffuse * self.h * 0.5 * (g + slope)


class OpticalModel:
    """Colour (shaded, non-associated) and extinction at world points.

    Args:
        scene: a resolved :class:`~dvr_gl.scene.resolve.Scene`; its field (:mod:`dvr_gl.fields`: a
            grid, or an analytic field for closed forms) reconstructed by the scene's filter.
        exact: evaluate the transfer function exactly (converged reference)
            instead of through the ``lut_size`` table (as the GPU does).
        segment_length: the length pre-integration tables are made for
            (default: the sample distance; slicing uses its slice spacing).
    """

    def __init__(self, scene, exact: bool = False, segment_length: float | None = None):
        r = scene.renderer
        self.tf: TransferFunction = scene.transfer_function
        self.scalar = reconstruct(scene.field, r)
        self.table = self.tf if exact else self.tf.tabulate(r.lut_size)
        if is_2d(self.tf):  # by value and gradient magnitude: its own table, post-classified
            check_scene(scene)
            self.table = self.tf if exact else self.tf.tabulate_2d()
            self.classify = GradientClassifier(self.scalar, self.table)
        elif r.classification == "pre" and r.compositing in CLASSIFIED_ALONG_RAY:
            self.classify = PreClassifier(scene.field, self.tf, r.filter, r.associated_colors,
                                          **filter_parameters(r))
        else:
            self.classify = PostClassifier(self.scalar, self.table)
        self.preintegration = None
        if r.classification == "preintegrated" and r.compositing == "emission_absorption" and not exact:
            self.preintegration = preintegrate(self.tf, segment_length or r.sample_distance,
                                               r.preintegration_size, r.preintegration, r.lut_size)
        xray = r.compositing == "xray"  # absorption only: no shading, no gradient opacity
        self.shading = r.shading if r.shading.enabled and not xray else None
        self.epsilon = gradient_epsilon(scene.field)
        self.gradient_reference = r.gradient_opacity_reference if r.gradient_opacity and not xray else None
        self.depth_cue = depth_cue(scene) if r.compositing in ("average", "xray") and r.depth_cue < 1.0 else None
        self.by_cell = hasattr(self.scalar, "pieces")  # a mesh: its pieces know their cells
        self.scattering = None
        self.albedo_column = False
        scattering = getattr(r, "scattering", None)
        if scattering is not None and scattering.enabled and r.compositing == "emission_absorption":
            from ..scene.settings import albedo_column

            self.albedo_column = albedo_column(r, self.tf)
            if exact:  # shadow rays integrated between the field's knots, to the pixel's budget; with
                # Gauss-Legendre exact for the field's polynomial pieces, only pieces holding a
                # transfer-function breakpoint are bisected
                nodes = max(1, -(-(int(getattr(self.scalar, "degree", 3)) + 1) // 2))
                self.scattering = SingleScattering(scene, self.extinction, pieces=self._shadow_pieces,
                                                   tolerance=r.converged_tolerance, nodes=nodes)
            else:  # marched at the shadow step, as the ray caster's shadow rays
                from ..scene.settings import shadow_step

                self.scattering = SingleScattering(scene, self.extinction, step=shadow_step(r, scene.field))
        self.hemispherical = None
        if r.compositing in ("average", "xray") and r.hemispherical_shading:
            if scene.field.kind != "grid":
                from ..errors import SceneError

                raise SceneError("renderer.hemispherical_shading shades with the gradient magnitudes of a grid's "
                                 f"samples; {scene.field.kind} data has no grid: turn it off")
            if r.compositing == "average":
                self.hemispherical = HemisphericalShading(scene, lambda p: self.scalar.sample(p)[:, None],
                                                          np.asarray(scene.field.data, np.float64))
            else:  # the emission sigma c of the pre-classified voxels (associated), or post-classified points
                voxels = self.tf.classify_voxels(scene.field.samples, True)[..., :3]
                self.hemispherical = HemisphericalShading(scene, self._emitted, voxels)

    def albedo(self, points, cells=None) -> np.ndarray | None:
        """The albedo at points from the transfer function's column (tabulated as the GPU's, or exact), or
        None where the scene gives one number."""
        if not self.albedo_column:
            return None
        return self.table.albedo(self.values(points, cells if self.by_cell else None))

    def _shadow_pieces(self, origins, directions, t0, t1):
        """Smooth pieces ``(ray, a, b, cell)`` of shadow rays (a grid's between its filter's knots)."""
        if self.by_cell:
            return self.scalar.pieces(origins, directions, t0, t1)
        from ..fields.reconstruction import smooth_pieces

        ray, a, b = smooth_pieces(self.scalar, origins, directions, t0, t1)
        return ray, a, b, np.zeros(len(ray), np.int64)

    def extinction(self, points: np.ndarray, cells: np.ndarray | None = None) -> np.ndarray:
        """``sigma`` at points, scaled by gradient-magnitude opacity if the scene asks (what attenuates
        a shadow ray as it attenuates the view's); ``cells``: as in :meth:`values` (ignored on grids)."""
        cells = cells if self.by_cell else None
        _, sigma = self.classify(points, None if cells is None else self.values(points, cells))
        if self.gradient_reference is not None:
            gradient = self.gradients(points, cells)
            sigma = sigma * np.minimum(1.0, np.linalg.norm(gradient, axis=1) / self.gradient_reference)
        return sigma

    def _emitted(self, points: np.ndarray) -> np.ndarray:
        """``sigma c`` at points (unshaded)."""
        colour, sigma = self.classify(points, None)
        return colour * sigma[:, None]

    def xray_emission(self, points: np.ndarray, directions: np.ndarray, cells=None):
        """``(emitted sigma c (N, 3), sigma (N,))`` of the X-ray at points: hemispherically shaded and
        depth-cued if the scene asks."""
        colour, sigma = self.classify(points, None if cells is None else self.values(points, cells))
        emitted = colour * sigma[:, None] if self.hemispherical is None else self.hemispherical(points)
        if self.depth_cue is not None:
            emitted = emitted * self.depth_cue(points)[:, None]
        return emitted, sigma

    def projected_values(self, points: np.ndarray, cells=None) -> np.ndarray:
        """What the average adds up at points: the scalar, hemispherically shaded and depth-cued if asked."""
        s = self.values(points, cells) if self.hemispherical is None else self.hemispherical(points)[:, 0]
        return s if self.depth_cue is None else s * self.depth_cue(points)

    def values(self, points: np.ndarray, cells: np.ndarray | None = None) -> np.ndarray:
        """The scalar at points; ``cells``: for a mesh, the cell holding each point where the caller
        knows it (a ray's pieces), so that it is not located again."""
        return self.scalar.sample(points) if cells is None else self.scalar.sample_cells(cells, points)

    def gradients(self, points: np.ndarray, cells: np.ndarray | None = None) -> np.ndarray:
        return self.scalar.gradient(points) if cells is None else self.scalar.gradient_cells(cells, points)

    def emission(self, points: np.ndarray, directions: np.ndarray,
                 cells: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(colour (N, 3), sigma (N,))`` at points: shaded, and extinction scaled by
        ``min(1, |gradient| / reference)`` (gradient-magnitude opacity), if the scene asks.
        ``cells``: as in :meth:`values`."""
        colour, sigma = self.classify(points, None if cells is None else self.values(points, cells))
        if self.scattering is not None:
            colour = colour * self.scattering.factor(points, directions, self.albedo(points, cells))
        if self.shading is None and self.gradient_reference is None:
            return colour, sigma
        gradient = self.gradients(points, cells)
        if self.gradient_reference is not None:
            sigma = sigma * np.minimum(1.0, np.linalg.norm(gradient, axis=1) / self.gradient_reference)
        if self.shading is not None:
            colour = blinn_phong(colour, normals_from_gradient(gradient, self.epsilon), directions, self.shading)
        return colour, sigma

    def preintegrated(self, front, back, middle, directions, fraction):
        """Associated colour and optical depth of segments from the pre-integration table: the scalar
        at their ``front`` and ``back`` points, lengths as ``fraction`` of the table's; gradient opacity
        scales the optical depth and shading the mean colour ``C / alpha``, both at ``middle``."""
        premult, tau = self.preintegration.lookup(self.scalar.sample(front), self.scalar.sample(back))
        premult, tau = shortened(premult, tau, fraction)
        if self.scattering is not None:  # the segment lit as its middle is (as shading is)
            premult = premult * self.scattering.factor(middle, directions, self.albedo(middle))
        if self.shading is None and self.gradient_reference is None:
            return premult, tau
        gradient = self.scalar.gradient(middle)
        if self.gradient_reference is not None:
            premult, tau = shortened(premult, tau, np.minimum(1.0, np.linalg.norm(gradient, axis=1) /
                                                             self.gradient_reference))
        if self.shading is not None:
            alpha = -np.expm1(-tau)
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.where(alpha[:, None] > 0, premult / alpha[:, None], 0.0)
            normal = normals_from_gradient(gradient, self.epsilon)
            premult = blinn_phong(mean, normal, directions, self.shading) * alpha[:, None]
        return premult, tau

    def shade(self, colour, points, directions, cells=None):
        normal = normals_from_gradient(self.gradients(points, cells), self.epsilon)
        return blinn_phong(colour, normal, directions, self.shading)

    def breakpoints(self) -> np.ndarray:
        """Scalar values where emission or extinction has a kink along a ray: the transfer function's
        breakpoints under post-classification; none under pre-classification (the classified field
        is interpolated like the scalar, smooth between knots)."""
        if isinstance(self.classify, PreClassifier):
            return np.zeros(0)
        return self.tf.breakpoints()

    def classify_value(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Colour and opacity for projected scalars (average, MIP, MinIP, isosurface colour):
        the opacity over one ``unit_distance``."""
        colour, sigma = self.table.lookup(values) if hasattr(self.table, "lookup") else self.table.evaluate(values)
        return colour, -np.expm1(-sigma * self.tf.unit_distance)
