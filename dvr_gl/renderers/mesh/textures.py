"""What the GL renderers of tetrahedral meshes share: the mesh on the GPU, once, as textures of 4096
texels a row (points relative to the mesh's centre, so float32 keeps their precision; cells; each
cell's four face planes, their sides and its scalar as ``g . p + c``, computed in float64:
``shaders/mesh_fetch.glsl``), the camera's and the exact
transfer function's uniforms, the limits, and the host's classification of projections (MIP,
MinIP, average, isosurface) with the exact transfer function, as the converged reference does.
The frame around them (context, targets, read-back, binding, release) is the GL frame kit's
(:class:`~dvr_gl.renderers.base.GLRenderer`).
"""

from __future__ import annotations

import functools

import moderngl
import numpy as np

from ... import limits
from ...clipping import ClipRegion
from ...errors import SceneError
from ...fields.mesh_rays import FacePlanes
from ...geometry import chord_lengths
from ...gl.geometry import box_corners, clip_planes, gl_matrix, projection_matrix, view_matrix
from ...reference.converged import collocation
from ...transfer_function import extinction_from_alpha, segment_opacity
from ..base import GLRenderer
from ..surfaces import with_surfaces

ROW = 4096  # texels a row of the mesh textures (mesh_fetch.glsl)
CELL_TEXELS = 6  # a cell's face planes, their sides and its scalar (mesh_fetch.glsl)
FOLDED_TEXELS = 5  # the same with each plane's side folded into it (FOLDED_PLANES in mesh_fetch.glsl)
# How far a footprint is grown (pt.geom), pixels.  The rasterizer snaps vertices to a sub-pixel grid
# (llvmpipe: 1/256 pixel), so a pixel centre just inside a cell's silhouette can fall outside the
# drawn footprint, and with it a piece of the cell (all of a thin cell seen edge on): without a
# margin the blunt fin was off by RMS 4e-5 to 8e-5 (2.5e-7 with one).  A twentieth of a pixel covers
# the snapping at a fraction of the fragments a whole pixel adds (20-30 % more draw time).
MARGIN_PIXELS = 0.05
MODES = {"emission_absorption": "EMISSION", "mip": "MIP", "minip": "MINIP", "average": "AVERAGE",
         "isosurface": "ISOSURFACE"}


def rows(array: np.ndarray, dtype, components: int = 4) -> np.ndarray:
    """``(n, components)`` as ``(rows, ROW, components)`` texels, zero-padded."""
    rows = max(1, -(-len(array) // ROW))
    out = np.zeros((rows * ROW, components), dtype=dtype)
    out[:len(array)] = array.reshape(len(array), components)
    return out.reshape(rows, ROW, components)


def cell_texels(points: np.ndarray, tets: np.ndarray, gradients: np.ndarray, offsets: np.ndarray,
                folded: bool = False) -> np.ndarray:
    """``(M * CELL_TEXELS, 4)``: each cell's face planes ``(n, h)`` (as :class:`FacePlanes`, so the cells
    sharing a face hold the same plane), the side of each its inside lies on, and its scalar ``(g, c)``.
    ``folded``: ``(M * FOLDED_TEXELS, 4)``, each plane times its side (inside is ``n . p - h >= 0``;
    negation is exact, so the cells sharing a face still hold the same numbers up to sign), then the
    scalar."""
    planes = FacePlanes(points, tets)
    if folded:
        out = np.zeros((len(tets), FOLDED_TEXELS, 4))
        out[:, :4, :3] = planes.normal * planes.side[..., None]
        out[:, :4, 3] = planes.offset * planes.side
        out[:, 4, :3], out[:, 4, 3] = gradients, offsets
        return out.reshape(-1, 4)
    out = np.zeros((len(tets), CELL_TEXELS, 4))
    out[:, :4, :3], out[:, :4, 3], out[:, 4] = planes.normal, planes.offset, planes.side
    out[:, 5, :3], out[:, 5, 3] = gradients, offsets
    return out.reshape(-1, 4)


def interval_sigma_max(tf) -> np.ndarray:
    """``(TF_COUNT + 1,)``: the largest extinction inside each control interval of ``tf``, below the
    first value and above the last included (transfer_segment.glsl sizes its steps by it): the
    opacity column is linear inside an interval and the extinction grows with it, so it is the
    larger end's."""
    column = tf.points[:, 4]
    ends = np.maximum(np.r_[column[0], column], np.r_[column, column[-1]])
    if tf.opacity_model == "alpha":
        return extinction_from_alpha(ends, tf.unit_distance)
    return ends


class MeshTextures:
    """One mesh on the GPU.  ``folded``: only the cells' planes, folded (:func:`cell_texels`), for a
    renderer that never looks at the points (one walking from cell to cell by their planes)."""

    def __init__(self, ctx, mesh, folded: bool = False):
        lo, hi = (np.asarray(b, float) for b in mesh.bounds)
        self.centre = 0.5 * (lo + hi)
        rec = mesh.reconstruct()
        points = mesh.points - self.centre
        offset = rec.base - np.einsum("ij,ij->i", rec.gradients, rec.anchor - self.centre)
        planes = cell_texels(points, mesh.tets, rec.gradients, offset, folded)
        self.textures = []
        uploads = [("u_cell_planes", planes, "f4")]
        if not folded:
            uploads[:0] = [("u_points", np.c_[points, np.zeros(len(points))], "f4"), ("u_cells", mesh.tets, "u4")]
        for name, data, dtype in uploads:
            texels = rows(data, np.float32 if dtype == "f4" else np.uint32)
            tex = ctx.texture((ROW, texels.shape[0]), 4, texels.tobytes(), dtype=dtype)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.textures.append((name, tex))
        self.cells = len(mesh.tets)
        self.ctx = ctx
        self._boundary = None  # the boundary faces' vertices (a buffer), once asked for
        values = mesh.values[mesh.tets] if mesh.association == "point" else mesh.values[:, None]
        self.cell_ranges = (values.min(axis=1), values.max(axis=1))  # each cell's scalar range
        self._visible = None  # (transfer function, mask)

    def visible(self, tf) -> np.ndarray:
        """Which cells hold some opacity under ``tf`` over their scalar range (once per transfer function,
        :meth:`~dvr_gl.transfer_function.TransferFunction.opaque_somewhere`).  The others add nothing
        (premultiplied (0, 0)) and are not drawn."""
        if self._visible is None or self._visible[0] is not tf:
            self._visible = (tf, tf.opaque_somewhere(*self.cell_ranges))
        return self._visible[1]

    def boundary(self, adjacency):
        """A buffer of the mesh's boundary triangles (centre-relative float32 vertices) and their count."""
        if self._boundary is None:
            corners = (adjacency.boundary_corners - self.centre).astype(np.float32)
            self._boundary = (self.ctx.buffer(corners.tobytes()) if len(corners) else None, len(corners))
        return self._boundary

    def release(self):
        for _, tex in self.textures:
            tex.release()
        if self._boundary is not None and self._boundary[0] is not None:
            self._boundary[0].release()


@functools.cache
def _gauss_legendre() -> tuple[tuple, tuple, bytes]:
    """The 4-point Gauss-Legendre rule on [0, 1] as the shaders take it: nodes, weights, and the
    spectral integration matrix (S on [0, 1]: the integral from 0 to x_i of l_j, half of that on
    [-1, 1]; column j, row i) as float32 bytes.  Once per process (numpy's ``leggauss`` costs about
    a millisecond, twice a frame)."""
    x, w, s = collocation(4)
    return tuple(0.5 * (x + 1.0)), tuple(0.5 * w), np.ascontiguousarray((0.5 * s).T, dtype=np.float32).tobytes()


class _KeptMesh:
    """A mesh's textures and what its renderer built beside them (:meth:`MeshRenderer._mesh_extra`),
    kept and released together."""

    def __init__(self, textures: MeshTextures, extra):
        self.textures, self.extra = textures, extra

    def release(self):
        self.textures.release()
        if hasattr(self.extra, "release"):
            self.extra.release()


class MeshRenderer(GLRenderer):
    """A GL renderer of a tetrahedral mesh: the mesh's textures (with what the renderer builds beside
    them per mesh: :meth:`_mesh_extra`), uniforms, limits."""

    folded_planes = False  # the mesh's textures: the planes folded, no points (MeshTextures)

    # --- limits ---

    def check_textures(self, scene, gl):
        """The mesh's textures against the texture limit, the exact transfer function's control points
        against the fragment shader's uniforms."""
        mesh = scene.field
        texels = FOLDED_TEXELS if self.folded_planes else CELL_TEXELS
        rows = -(-max(len(mesh.points), texels * len(mesh.tets)) // ROW)
        limits.check_texture("the mesh", (ROW, rows), gl, "use a smaller mesh")
        points = len(scene.transfer_function.points)
        if scene.renderer.compositing == "emission_absorption" and points > self.max_tf_points():
            raise SceneError(f"transfer_function.points: {points} control points; {self.name} keeps them "
                             f"in uniforms and this GL holds at most {self.max_tf_points()}: use fewer points")

    def max_tf_points(self) -> int:
        """Control points the fragment shader's uniforms hold: two vectors each, 64 kept for the rest."""
        vectors = int(self.ctx.info["GL_MAX_FRAGMENT_UNIFORM_COMPONENTS"]) // 4
        return max(vectors - 64, 0) // 2

    # --- a frame ---

    def draw(self, scene) -> np.ndarray:
        """The frame; with ``[[renderer.geometry]]`` the meshes are drawn first (:mod:`.surfaces`), each
        ray's integration ends at them and the frame is composited over them."""
        self.activate()
        return with_surfaces(self, scene, self._draw_volume)

    def _draw_volume(self, scene, surfaces: dict) -> np.ndarray:
        """The mesh's frame, rows from the top; ``surfaces``: ``u_geometry`` where meshes end the rays."""
        raise NotImplementedError

    @staticmethod
    def _kept_part_defines(scene, surfaces: dict) -> dict:
        """``shaders/kept_part.glsl``'s defines: the clipping region's, and GEOMETRY."""
        clip = ClipRegion.of(scene.renderer)
        return {**(clip.defines() if clip is not None else {}), "GEOMETRY": "u_geometry" in surfaces}

    # --- resources ---

    def _mesh_resources(self, mesh):
        """The mesh's textures and what :meth:`_mesh_extra` builds beside them, once per mesh."""
        def make():
            textures = MeshTextures(self.ctx, mesh, self.folded_planes)
            return _KeptMesh(textures, self._mesh_extra(mesh, textures))

        kept = self._cached("mesh", (mesh,), make)
        return kept.textures, kept.extra

    def _mesh_extra(self, mesh, textures):
        """What the renderer keeps per mesh beside its textures (released with them if it has ``release``)."""
        return None

    @staticmethod
    def _near_plane(scene) -> tuple[float, np.ndarray]:
        """The GL near plane's distance from the eye along the view axis, with a margin for float32
        rounding there, and the view axis."""
        lo, hi = (np.asarray(b, float) for b in scene.field.bounds)
        near, _ = clip_planes(scene.camera, lo, hi)
        forward, _, _ = scene.camera.basis()
        return near + 1e-6 * float(np.linalg.norm(hi - lo)), forward

    @staticmethod
    def _reaches_near_plane(scene) -> bool:
        """Whether the mesh's box reaches the GL near plane."""
        near, forward = MeshRenderer._near_plane(scene)
        corners = box_corners(*scene.field.bounds)
        return bool(((corners - np.asarray(scene.camera.eye)) @ forward).min() <= near)

    @staticmethod
    def view_projection(scene, centre) -> np.ndarray:
        """``(4, 4)`` float64: points relative to ``centre`` (the mesh textures') to clip coordinates, the
        GL near and far planes around the mesh's box."""
        cam, img = scene.camera, scene.image
        near, far = clip_planes(cam, *scene.field.bounds)
        translate = np.eye(4)
        translate[:3, 3] = centre
        return projection_matrix(cam, img.width / img.height, near, far) @ view_matrix(cam) @ translate

    def _uniforms(self, program, scene, textures):
        cam, img, r = scene.camera, scene.image, scene.renderer
        vp = self.view_projection(scene, textures.centre)
        f, right, up = cam.basis()
        x, w, s = _gauss_legendre()
        values = {"u_image_size": (img.width, img.height), "u_margin": MARGIN_PIXELS,
                  "u_eye": tuple(np.asarray(cam.eye) - textures.centre), "u_forward": tuple(f),
                  "u_right": tuple(right), "u_up": tuple(up),
                  "u_half_extent": cam.half_extent(img.width / img.height), "u_near": cam.near,
                  "u_iso_value": r.iso_value if r.iso_value is not None else 0.0,
                  "u_depth_scale": 1.0 / self._far(scene),
                  "u_unit_distance": scene.transfer_function.unit_distance,
                  "u_gauss_x": x, "u_gauss_w": w}
        clip = ClipRegion.of(r)
        if clip is not None:  # the rays are relative to the mesh's centre (u_eye), the region too
            values.update(clip.shifted(textures.centre).uniforms())
        self.bind(program, values, {})
        if "u_view_projection" in program:
            program["u_view_projection"].write(gl_matrix(vp))
        if "u_gauss_s" in program:
            program["u_gauss_s"].write(s)
        p = scene.transfer_function.points
        if "u_tf_sigma_max" in program:
            program["u_tf_sigma_max"].write(interval_sigma_max(scene.transfer_function).astype(np.float32).tobytes())
        for name, columns in (("u_tf_value_opacity", [0, 4]), ("u_tf_rgb", [1, 2, 3])):
            if name in program:  # (a shader may leave out the colours: WALK_STATS)
                program[name].write(np.ascontiguousarray(p[:, columns], dtype=np.float32).tobytes())

    @staticmethod
    def _far(scene) -> float:
        """The largest ray parameter inside the mesh's box (the isosurface's depth scale)."""
        corners = box_corners(*scene.field.bounds)
        return float(np.linalg.norm(corners - np.asarray(scene.camera.eye), axis=1).max()) * 1.01 + 1e-30

    @staticmethod
    def _resolve(scene, image) -> np.ndarray:
        """Classify a projection's blended value (``.r``) where a fragment came (``.g``), with the exact
        transfer function and the opacity of one unit distance; the isosurface: its colour, opaque."""
        mode, tf = scene.renderer.compositing, scene.transfer_function
        value, flag = image[..., 0], image[..., 1]
        covered = flag < 0 if mode == "minip" else flag > 0
        if mode == "isosurface":
            value = np.full(value.shape, scene.renderer.iso_value)
        elif mode == "average":
            length = chord_lengths(scene)
            value = np.where(length > 0, value / np.where(length > 0, length, 1.0), 0.0)
        colour, sigma = tf.evaluate(value[covered])
        alpha = 1.0 if mode == "isosurface" else segment_opacity(sigma, tf.unit_distance)
        out = np.zeros(image.shape)
        out[covered, :3] = colour * np.reshape(alpha, (-1, 1))
        out[covered, 3] = alpha
        return out
