"""The grid sampling kit: the base of the GL renderers that sample a regular voxel grid in their
shaders (the ray caster, the slicers).

A :class:`GridRenderer` is a :class:`~dvr_gl.renderers.base.GLRenderer` that draws a frame as passes
over grid views (:mod:`.views`: the whole volume or its bricks, a brick maybe from a coarser level),
each with the view's textures (:mod:`.textures`: scalar volume, pre-classified copy, gradients) kept
in the frame's cache or, for bricks read apart, in the texture budget's LRU cache (:mod:`.lru`); with
the tables (:mod:`.tables`), the defines and uniforms of classification (:mod:`.classification`) and,
where the scene scatters light, the light volume (:mod:`dvr_gl.gl.scattering`).  Renderers that
sample no grid on the GPU (compositing on the host, splatting kernels, slicing a spectrum, drawing
meshes) are GL renderers without it.
"""

from __future__ import annotations

import time

import numpy as np

from ... import limits
from ...errors import SceneError
from ...gl.scattering import LightVolumeTexture, light_volume_key, light_volume_pass_defines
from ..base import GLRenderer
from .classification import classified_voxels, optics_uniforms
from .lru import TextureLRU
from .tables import check_tables
from .tables import table_textures as frame_tables
from .textures import FORMATS, central_difference_gradients, upload_field, upload_volume
from .views import GridView, grid_uniforms, level_view, plan_views


class GridRenderer(GLRenderer):
    """A GL renderer sampling a voxel grid (see the module doc)."""

    def __init__(self, ctx=None):
        super().__init__(ctx)
        self.bricks = TextureLRU()  # brick textures read apart (out of core, coarser levels)

    def check_textures(self, scene, gl: "limits.GLLimits"):
        """The tables (:func:`.tables.check_tables`); the volume is bricked to fit (:meth:`grid_views`)."""
        check_tables(scene, gl)

    # --- what to sample: the volume or its bricks ---

    def grid_texture_limit(self, gl: "limits.GLLimits") -> int:
        """The largest grid (brick) edge one texture may hold: a 3D texture's side."""
        return gl.texture_3d_size

    @staticmethod
    def texture_bytes_per_voxel(defines) -> int:
        """Texture bytes a voxel costs beside its scalar: the classified copy, the gradients."""
        return 16 * ("CLASSIFY_PRE" in defines) + 12 * ("GRADIENT_TEXTURE" in defines)

    def grid_views(self, scene, defines) -> list[GridView]:
        """The frame's grid views (:func:`.views.plan_views`) within this renderer's texture limit."""
        per_voxel = FORMATS[scene.volume.dtype][3] + self.texture_bytes_per_voxel(defines)
        limit = self.grid_texture_limit(limits.gl_limits(self.ctx))
        return plan_views(scene, defines, per_voxel, limit, self.brick_reach(scene))

    level_view = staticmethod(level_view)

    def brick_reach(self, scene) -> float:
        """How far (voxels along any axis) beyond a brick's core this renderer samples for what the
        core owns; point samples in the core only: 0."""
        return 0.0

    # --- textures ---

    def view_textures(self, scene, defines, view: GridView, resident: bool) -> dict:
        """The textures of one grid view: scalar volume, classified copy, gradients.  ``resident``:
        keep them cached (all bricks fit the budget) rather than replace them per pass.  A volume read
        out of core, or a brick drawn from a coarser level, goes through :attr:`bricks`, the texture
        budget's least-recently-used cache, its voxels read (:meth:`Volume.read`) only when missing."""
        volume = scene.volume
        if volume.out_of_core or view.level:
            return self._brick_textures(scene, defines, view)
        tag = f"view {view.tex_lo}" if resident else "view"
        key = (volume, view.tex_lo, view.dims)

        def part(array):
            return view.brick.data(array) if view.brick is not None else array

        out = {"u_volume": self._cached(tag + " volume", key, lambda: upload_volume(
            self.ctx, _SubVolume(volume.read(view.tex_lo, view.dims) if view.brick is not None else volume.data)))}
        if "CLASSIFY_PRE" in defines:
            voxels = self._classified_voxels(scene)
            out["u_classified"] = self._cached(tag + " classified", key + (voxels,),
                                               lambda: upload_field(self.ctx, part(voxels)))
        if "GRADIENT_TEXTURE" in defines:
            out["u_gradient"] = self._cached(tag + " gradient", key, lambda: upload_field(
                self.ctx, part(self._cached("gradients", (volume,), lambda: central_difference_gradients(volume)))))
        return out

    def _brick_textures(self, scene, defines, view: GridView) -> dict:
        """A brick's textures through the LRU cache :attr:`bricks` (bounded by
        ``renderer.texture_budget_mb``): the voxels read from the volume or its level, classified per
        voxel where the frame pre-classifies (pointwise: the same as the whole volume's)."""
        if "GRADIENT_TEXTURE" in defines:
            raise SceneError(f"renderer.gradient = 'texture' needs the whole volume's gradients, and "
                             f"{scene.volume.name} is drawn in bricks read apart; use gradient = 'central' "
                             f"(the shader's central differences)")
        r, grid = scene.renderer, view.grid or scene.volume
        classify = "CLASSIFY_PRE" in defines
        key = (id(grid), view.tex_lo, view.dims, classify and (id(scene.transfer_function), r.associated_colors))

        def make():
            voxels = grid.read(view.tex_lo, view.dims)
            out = {"u_volume": upload_volume(self.ctx, _SubVolume(voxels))}
            if classify:
                classified = scene.transfer_function.classify_voxels(voxels, r.associated_colors)
                out["u_classified"] = upload_field(self.ctx, classified.astype(np.float32))
            return out, voxels.size * (FORMATS[voxels.dtype][3] + 16 * classify)

        self.bricks.budget = int(r.texture_budget_mb * 2 ** 20)
        return self.bricks.get(key, make, alive=(grid, scene.transfer_function))

    def _classified_voxels(self, scene) -> np.ndarray:
        return classified_voxels(self, scene)

    def table_textures(self, scene, defines, slab_length: float) -> dict:
        """The frame's tables (:func:`.tables.table_textures`)."""
        return frame_tables(self, scene, defines, slab_length)

    # --- scattering ---

    def scattering_tables(self, scene, defines, views, tables) -> tuple[dict, float]:
        """The frame's tables with what scattering needs (the light volume, if the scene asks for it), and
        the seconds its making took this frame (0 when it was kept); a bricked volume is refused (the
        lights' rays cross bricks)."""
        if "SCATTERING" not in defines:
            return tables, 0.0
        if len(views) > 1:
            raise SceneError(f"{scene.renderer.name} renders scattering from one texture of the whole volume (the "
                             f"lights' rays cross bricks), and {scene.volume.name} needs {len(views)} bricks at "
                             f"renderer.texture_budget_mb = {scene.renderer.texture_budget_mb:g}: raise it or "
                             f"turn renderer.scattering off")
        if "LIGHT_VOLUME" not in defines:
            return tables, 0.0
        made = self._cache.get("light volume")
        light = self.light_volume_texture(scene, defines, views[0], tables["u_lut"])
        return {**tables, "u_light_volume": light}, (light.seconds if made is None or made[1] is not light else 0.0)

    def light_volume_texture(self, scene, defines, view, lut_texture) -> LightVolumeTexture:
        """The frame's light volume (common/scattering.glsl's LIGHT_VOLUME), marched through ``view``'s
        textures and cached by what it depends on (:func:`dvr_gl.gl.scattering.light_volume_key`)."""
        pass_defines = light_volume_pass_defines(defines)

        def make():
            started = time.perf_counter()  # the view's upload, where the pass makes it, counts as the pass's
            textures = {**self.view_textures(scene, pass_defines, view, resident=True), "u_lut": lut_texture}
            uniforms = {**self.grid_uniforms(scene, view), **self.optics_uniforms(scene, lut_texture.lut)}
            return LightVolumeTexture(self, scene, pass_defines, textures, uniforms, started)

        return self._cached("light volume", light_volume_key(scene, pass_defines), make)

    # --- uniforms ---

    grid_uniforms = staticmethod(grid_uniforms)
    optics_uniforms = staticmethod(optics_uniforms)

    def close(self):
        self.activate()
        self.bricks.release()
        super().close()


class _SubVolume:
    """Enough of a Volume for :func:`upload_volume`: a data array."""

    def __init__(self, data):
        self.data = data
