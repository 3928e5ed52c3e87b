"""What the GPU renderers share: context, cached textures, uniforms, float render targets.

Textures are cached by what they were made from (objects by identity, values
by value), so an orbit re-renders without uploads and a transfer-function edit
re-uploads only its table.  The voxel grid a program samples is a *grid view*:
the whole volume, or one brick of it (first voxel and size), so bricked and
unbricked rendering share every shader and uniform.
"""

from __future__ import annotations

import time
from collections import OrderedDict

import moderngl
import numpy as np

from ... import limits
from ...clipping import ClipRegion
from ...errors import DvrError, SceneError
from ...fields import gradient_epsilon
from ...gl.context import create_context, make_current, release_context
from ...gl.lights import set_uniform, shading_uniforms
from ...gl.shaders import release_programs
from ...preintegration import preintegrate
from ...reference.scattering import light_volume_dims
from ...scene.settings import albedo_column, constant_albedo, shadow_step
from ..base import Renderer
from .bricking import brick_size_for, ghost_width, plan_bricks
from .textures import FORMATS, central_difference_gradients, upload_field, upload_table, upload_volume

# A volume read out of core is drawn in bricks of at most 1 / OUT_OF_CORE_BRICKS of its host-memory budget.
OUT_OF_CORE_BRICKS = 8

FILTER = {"nearest": "FILTER_NEAREST", "linear": "FILTER_LINEAR", "cubic_bspline": "FILTER_CUBIC_BSPLINE",
          "catmull_rom": "FILTER_CATMULL_ROM"}


def classification_features(scene) -> dict:
    """Defines for filtering, classification, shading and gradients: what every renderer's
    classify() (dvr_gl/gl/shaders/common/classify.glsl) needs.  Emission-absorption only."""
    r = scene.renderer
    defines = {FILTER[r.filter]: True}
    if r.filtering == "shader" and r.filter != "nearest":
        defines["FILTER_IN_SHADER"] = True
    if scene.camera.projection == "orthographic":
        defines["CAMERA_ORTHOGRAPHIC"] = True
    defines["CLASSIFY_PRE"] = r.classification == "pre"
    defines["CLASSIFY_PREINTEGRATED"] = r.classification == "preintegrated"
    defines["ASSOCIATED_COLORS"] = r.classification == "pre" and r.associated_colors
    defines["GRADIENT_OPACITY"] = r.gradient_opacity
    shading_defines(scene, defines)
    scattering_defines(scene, defines)
    clip = ClipRegion.of(r)
    if clip is not None:  # every mode: common/clipping.glsl
        defines.update(clip.defines())
    defines["GEOMETRY"] = bool(getattr(r, "geometry", None))  # samples end at the meshes' surfaces
    return {k: v for k, v in defines.items() if v is not False}


def scattering_defines(scene, defines: dict):
    """Single scattering (dvr_gl/gl/shaders/common/scattering.glsl), only where the scene enables it."""
    sc = getattr(scene.renderer, "scattering", None)
    if sc is None or not sc.enabled or scene.renderer.compositing != "emission_absorption":
        return
    defines.update(SCATTERING=True, NUM_SCATTER_LIGHTS=len(sc.lights), PHASE_HG=sc.phase == "henyey_greenstein",
                   SHADOWS=sc.shadows and sc.method == "shadow_rays",
                   LIGHT_VOLUME=sc.shadows and sc.method == "light_volume",
                   HALF_ANGLE=sc.shadows and sc.method == "half_angle",
                   ALBEDO_TABLE=albedo_column(scene.renderer, scene.transfer_function))


def light_volume_pass_defines(defines: dict) -> dict:
    """The light volume's pass (dvr_gl/gl/shaders/scattering/light_volume.frag): the frame's filtering and
    classification defines (the extinction its samples see; a pre-integrated frame's shadow rays
    classify points, post) and its lights, marching shadow rays."""
    keep = {k: v for k, v in defines.items() if k in PASS_KEYS or k.startswith("FILTER")}
    return {**keep, "SHADOWS": True}


PASS_KEYS = ("CLASSIFY_PRE", "ASSOCIATED_COLORS", "GRADIENT_OPACITY", "GRADIENT_TEXTURE", "SCATTERING",
             "NUM_SCATTER_LIGHTS", "PHASE_HG")


def scattering_uniforms(scene) -> dict:
    """The lights of single scattering: toward a directional light (w 0) or a point light's position
    (w 1), irradiance, albedo, phase, the shadow rays' step (the sample distance) and the nearest a
    point light counts as (half the smallest voxel, as dvr_gl.reference.scattering)."""
    sc, r = scene.renderer.scattering, scene.renderer
    if not sc.enabled:
        return {}
    lights = []
    for light in sc.lights:
        if light.type == "directional":
            w = np.asarray(light.direction, dtype=np.float64)
            lights.append((*(-w / np.linalg.norm(w)), 0.0))
        else:
            lights.append((*light.position, 1.0))
    lo, hi = scene.field.bounds
    return {"u_scatter_light": lights, "u_light_volume_dims": light_volume_dims(lo, hi, sc.light_volume_size),
            "u_scatter_irradiance": [tuple(light.intensity * np.asarray(light.color)) for light in sc.lights],
            "u_albedo": constant_albedo(r), "u_phase_g": sc.g, "u_shadow_step": shadow_step(r, scene.field),
            "u_min_light_distance": 0.5 * float(scene.field.sample_spacing)}


def shading_defines(scene, defines: dict):
    r = scene.renderer
    if r.shading.enabled and r.shading.lights:
        defines.update(SHADING=True, NUM_LIGHTS=len(r.shading.lights), TWO_SIDED=r.shading.two_sided)
    if defines.get("SHADING") or defines.get("GRADIENT_OPACITY"):
        defines["GRADIENT_TEXTURE"] = r.gradient == "texture"


def _same(a, b) -> bool:
    """Cache keys match: objects by identity, plain values (numbers, strings, and tuples of them) by value."""
    if a is b:
        return True
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(map(_same, a, b))
    plain = (int, float, str, bool, type(None), np.integer, np.floating, np.bool_)
    return isinstance(a, plain) and isinstance(b, plain) and a == b


def _release(value):
    """Release what a cache entry holds on the GPU (host data holds nothing)."""
    target = getattr(value, "texture", value)
    if hasattr(target, "release"):
        target.release()


class LightVolumeTexture:
    """Each light's optical depth at the light volume's nodes (a 32-bit float 3D texture with a channel
    per light, nearest; the shaders
    interpolate), marched by dvr_gl/gl/shaders/scattering/light_volume.frag in slabs of nodes; ``seconds``: what
    making it took (the recomputation a light or transfer-function change costs)."""

    MAX_ROWS = 8192  # a pass's target height: within every GL's texture limit

    def __init__(self, renderer, scene, defines, view, lut_texture):
        from ...gl.shaders import create_program

        start = time.perf_counter()
        ctx = renderer.ctx
        lo, hi = scene.field.bounds
        nx, ny, nz = self.dims = light_volume_dims(lo, hi, scene.renderer.scattering.light_volume_size)
        program = create_program(ctx, "fullscreen.vert", "scattering/light_volume.frag", defines)
        textures = {**renderer.view_textures(scene, defines, view, resident=True), "u_lut": lut_texture}
        uniforms = {**renderer.grid_uniforms(scene, view), **renderer.optics_uniforms(scene, lut_texture.lut),
                    "u_box_lo": lo, "u_box_hi": hi, "u_nodes": self.dims}
        slabs = max(1, self.MAX_ROWS // ny)
        depths = []
        vao = ctx.vertex_array(program, [])
        try:
            for first in range(0, nz, slabs):
                count = min(slabs, nz - first)
                renderer.bind(program, {**uniforms, "u_first_k": first}, textures)
                (_,), fbo = renderer.target("light volume", nx, ny * count)
                fbo.use()
                ctx.viewport = (0, 0, nx, ny * count)
                ctx.disable(ctx.BLEND | ctx.DEPTH_TEST)
                vao.render(mode=ctx.TRIANGLES, vertices=3)  # fullscreen.vert's one triangle
                depths.append(renderer.read(fbo, nx, ny * count)[::-1])  # read() turns rows top down
        finally:
            vao.release()
        # one channel per light: every sample fetches eight nodes, and on a CPU rasterizer a 256^3
        # volume of four channels (256 MiB) for one light made its frames 10-20 % longer than one channel
        lights = len(scene.renderer.scattering.lights)
        data = np.concatenate(depths).reshape(nz, ny, nx, 4)[..., :lights]
        self.texture = ctx.texture3d((nx, ny, nz), lights, np.ascontiguousarray(data).tobytes(), dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.depths = data
        self.seconds = time.perf_counter() - start

    def release(self):
        self.texture.release()


class PreintegrationTexture:
    """A pre-integration table and its N x N RGBA32F texture (x: front value, y: back value)."""

    def __init__(self, ctx, table):
        self.table = table
        data = np.ascontiguousarray(table.table.transpose(1, 0, 2), dtype=np.float32)  # rows: back value
        self.texture = ctx.texture((table.size, table.size), 4, data.tobytes(), dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.repeat_x = self.texture.repeat_y = False


class TableTexture:
    """A transfer-function table and its texture (the table knows its value domain)."""

    def __init__(self, ctx, lut):
        self.lut = lut
        self.texture = upload_table(ctx, lut.table)


class GridView:
    """The part of the voxel grid a pass samples: ``tex_lo`` (x, y, z) and ``dims`` of its texture, in
    the voxels of ``grid``: the scene's volume (None), or its coarser level ``level``."""

    def __init__(self, tex_lo=(0, 0, 0), dims=None, brick=None, level: int = 0, grid=None):
        self.tex_lo, self.dims, self.brick = tuple(tex_lo), tuple(dims), brick
        self.level, self.grid = level, grid


class TextureLRU:
    """Brick textures, least recently used first out, within ``budget`` bytes (the most recent entry
    stays even alone over it: a pass needs its brick); ``uploaded``: bytes uploaded so far, ``hits``
    and ``misses`` of :meth:`get`."""

    def __init__(self, budget: int = 0):
        self.budget, self.used, self.uploaded, self.hits, self.misses = budget, 0, 0, 0, 0
        self._entries: "OrderedDict[tuple, tuple[dict, int, tuple]]" = OrderedDict()

    def get(self, key: tuple, make, alive=()) -> dict:
        """The textures under ``key``, or ``make() -> (textures, bytes)`` made and kept; ``alive``: the
        objects whose ``id`` the key holds, referenced by the entry so that no other object takes an
        id while it is cached."""
        entry = self._entries.pop(key, None)
        if entry is None:
            self.misses += 1
            self._evict_for(0)
            textures, size = make()
            entry = (textures, size, alive)
            self.uploaded += size
            self.used += size
        else:
            self.hits += 1
        self._entries[key] = entry
        self._evict_for(0, keep=key)
        return entry[0]

    def _evict_for(self, nbytes: int, keep=None):
        while self._entries and self.used + nbytes > self.budget:
            key = next(iter(self._entries))
            if key == keep:
                break
            textures, size, _ = self._entries.pop(key)
            for tex in textures.values():
                _release(tex)
            self.used -= size

    def release(self):
        self.budget = 0
        self._evict_for(0)
        self._entries.clear()
        self.used = 0


class GLVolumeRenderer(Renderer):
    """Base of the GPU renderers (see the module doc)."""

    def __init__(self, ctx=None):
        super().__init__()
        self.ctx = ctx or create_context()
        self._owns_context = ctx is None
        self._cache: dict = {}   # what -> (key objects, texture or host data)
        self._targets: dict = {}
        self.bricks = TextureLRU()  # brick textures read apart (out of core, coarser levels)

    # --- limits: checked before anything is drawn ---

    def check_resources(self, scene):
        """The image against the render-target limit, the tables against the texture limit, and their
        memory (see :mod:`dvr_gl.limits`); the volume is bricked to fit (:meth:`grid_views`)."""
        super().check_resources(scene)
        self.activate()
        gl = limits.gl_limits(self.ctx)
        limits.check_image(scene, gl)
        limits.check_image_memory(scene, "gpu")
        self.check_tables(scene, gl)

    def check_tables(self, scene, gl: "limits.GLLimits"):
        """The transfer-function table (one texture row) and the pre-integration table (N x N)."""
        r = scene.renderer
        limits.check_table("renderer.lut_size", r.lut_size, gl, "one row")
        limits.check_lut_memory(r.lut_size)
        if r.classification == "preintegrated" and r.compositing == "emission_absorption":
            n = r.preintegration_size
            limits.check_table("renderer.preintegration_size", n, gl, f"{n} x {n} texels")

    def grid_texture_limit(self, gl: "limits.GLLimits") -> int:
        """The largest grid (brick) edge one texture may hold: a 3D texture's side."""
        return gl.texture_3d_size

    # --- caching ---

    def _cached(self, what: str, key: tuple, make):
        """``make()``, unless the entry ``what`` was made from the same key (objects by identity,
        plain values by value)."""
        entry = self._cache.get(what)
        if entry is not None and len(entry[0]) == len(key) and all(map(_same, entry[0], key)):
            return entry[1]
        if entry is not None:
            _release(entry[1])
        value = make()
        self._cache[what] = (key, value)
        return value

    # --- what to sample: the volume or its bricks ---

    def texture_bytes_per_voxel(self, defines) -> int:
        per = 0
        if "CLASSIFY_PRE" in defines:
            per += 16
        if "GRADIENT_TEXTURE" in defines:
            per += 12
        return per

    def grid_views(self, scene, defines) -> list[GridView]:
        """The whole volume if its textures fit the GL limit and the budget, else bricks that do; a
        volume read out of core (:mod:`dvr_gl.out_of_core`) always in bricks, each at most an eighth of
        ``renderer.memory_budget_mb`` (its host copy is read while the last one's texture lives)."""
        r, volume = scene.renderer, scene.volume
        per_voxel = FORMATS[volume.dtype][3] + self.texture_bytes_per_voxel(defines)
        limit = self.grid_texture_limit(limits.gl_limits(self.ctx))
        budget = r.texture_budget_mb * 2 ** 20
        whole = max(volume.dims) <= limit and np.prod(volume.dims) * per_voxel <= budget
        if whole and not volume.out_of_core and not volume.levels:
            return [GridView((0, 0, 0), volume.dims)]
        central = ("SHADING" in defines or "GRADIENT_OPACITY" in defines) and "GRADIENT_TEXTURE" not in defines
        ghost = ghost_width(r.filter, central, self.brick_reach(scene))
        brick_budget = budget
        if volume.out_of_core:
            brick_budget = min(budget, getattr(r, "memory_budget_mb", 4096.0) * 2 ** 20 / OUT_OF_CORE_BRICKS)
        edge = brick_size_for(volume, per_voxel, brick_budget, limit, ghost)
        if edge ** 3 * per_voxel > brick_budget or edge <= 2 * ghost + 1:
            raise DvrError(f"renderer.texture_budget_mb = {r.texture_budget_mb} cannot hold even a "
                           f"{2 * ghost + 2}^3 brick of {volume.name} ({ghost} ghost voxel{'s' * (ghost > 1)} a side); "
                           f"raise it")
        return [GridView(b.tex_lo, b.tex_dims, b) for b in plan_bricks(volume.dims, edge, ghost)]

    def level_view(self, scene, view: GridView, level: int) -> GridView:
        """``view``'s brick drawn from the volume's coarser level ``level`` (1: ``volume.levels[0]``): the
        level's voxels over the brick's texture box, with as many ghost voxels of the level as the
        brick has of level 0 (ownership stays level 0's: the shader's global coordinates)."""
        if level == 0 or view.brick is None:
            return view
        volume, b = scene.volume, view.brick
        grid = volume.levels[level - 1]
        o0, s0 = np.asarray(volume.origin), np.asarray(volume.spacing)
        ok, sk = np.asarray(grid.origin), np.asarray(grid.spacing)
        lo0 = o0 + np.asarray(b.core_lo) * s0
        hi0 = o0 + np.asarray(b.core_hi) * s0
        tex_hi = np.asarray(b.tex_lo) + np.asarray(b.tex_dims) - 1
        ghost = int(max(1, *(np.asarray(b.core_lo) - b.tex_lo), *(tex_hi - b.core_hi)))  # its widest side
        dims = np.asarray(grid.dims)
        lo = np.clip(np.floor((lo0 - ok) / sk).astype(int) - ghost, 0, dims - 1)
        hi = np.clip(np.ceil((hi0 - ok) / sk).astype(int) + ghost, 0, dims - 1)
        return GridView(tuple(int(v) for v in lo), tuple(int(v) for v in hi - lo + 1), view.brick, level, grid)

    def brick_reach(self, scene) -> float:
        """How far (voxels along any axis) beyond a brick's core this renderer samples for what the
        core owns; point samples in the core only: 0."""
        return 0.0

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

    def table_textures(self, scene, defines, slab_length: float) -> dict:
        r, tf = scene.renderer, scene.transfer_function
        out = {"u_lut": self._cached("lut", (tf, r.lut_size), lambda: TableTexture(self.ctx, tf.tabulate(r.lut_size)))}
        if defines.get("ALBEDO_TABLE"):  # scattering's albedo column, at the same nodes (r; gba unused)
            albedo = out["u_lut"].lut.albedo_table
            out["u_albedo_lut"] = self._cached("albedo lut", (tf, r.lut_size), lambda: upload_table(
                self.ctx, np.column_stack([albedo, np.zeros((len(albedo), 3))])))
        if "CLASSIFY_PREINTEGRATED" in defines:
            out["u_preint"] = self._cached(
                "preintegration", (tf, slab_length, r.preintegration_size, r.preintegration, r.lut_size),
                lambda: PreintegrationTexture(self.ctx, preintegrate(tf, slab_length, r.preintegration_size,
                                                                     r.preintegration, r.lut_size)))
        return out

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

    def light_volume_texture(self, scene, defines, view, lut_texture) -> "LightVolumeTexture":
        """The frame's light volume (common/scattering.glsl's LIGHT_VOLUME), cached by what it depends on:
        the volume, the transfer function, the lights and the shadow rays' step and classification."""
        r = scene.renderer
        pass_defines = light_volume_pass_defines(defines)
        key = (scene.volume, scene.transfer_function, repr(r.scattering.lights), r.scattering.light_volume_size,
               shadow_step(r, scene.field), repr(sorted(pass_defines.items())), r.lut_size,
               r.gradient_opacity_reference, r.kernel_width)
        return self._cached("light volume", key, lambda: LightVolumeTexture(self, scene, pass_defines, view,
                                                                             lut_texture))

    def _classified_voxels(self, scene) -> np.ndarray:
        """Pre-classified voxels (float32), shared by their textures and block classes."""
        r, volume, tf = scene.renderer, scene.volume, scene.transfer_function
        return self._cached("classified voxels", (volume, tf, r.associated_colors),
                            lambda: tf.classify_voxels(volume.data, r.associated_colors).astype(np.float32))

    # --- uniforms ---

    @staticmethod
    def grid_uniforms(scene, view: GridView) -> dict:
        vol = view.grid or scene.volume
        spacing = np.array(vol.spacing)
        return {"u_world_to_voxel_scale": 1.0 / spacing,
                "u_world_to_voxel_offset": -np.array(vol.origin) / spacing - np.array(view.tex_lo),
                "u_voxel_spacing": spacing, "u_dims": view.dims}

    @staticmethod
    def optics_uniforms(scene, lut) -> dict:
        """Transfer function, shading and lights (shared by every renderer's classify())."""
        r, field, tf = scene.renderer, scene.field, scene.transfer_function
        lut_lo, lut_hi = lut.domain
        u = {"u_unit_distance": tf.unit_distance, "u_gradient_reference": r.gradient_opacity_reference,
             "u_lut_size": r.lut_size, "u_lut_lo": lut_lo, "u_lut_scale": (r.lut_size - 1) / (lut_hi - lut_lo),
             "u_gradient_epsilon": gradient_epsilon(field), **shading_uniforms(r.shading)}
        clip = ClipRegion.of(r)
        return {**u, **scattering_uniforms(scene), **(clip.uniforms() if clip is not None else {})}

    set_uniform = staticmethod(set_uniform)

    def bind(self, program, uniforms: dict, textures: dict):
        for name, value in uniforms.items():
            self.set_uniform(program, name, value)
        for unit, (name, tex) in enumerate(textures.items()):
            getattr(tex, "texture", tex).use(location=unit)
            self.set_uniform(program, name, unit)
            if name == "u_volume":
                self.set_uniform(program, "u_value_scale", tex.value_scale)
                self.set_uniform(program, "u_value_offset", tex.value_offset)
            if name == "u_preint":
                lo, hi = tex.table.domain
                self.set_uniform(program, "u_preint_size", tex.table.size)
                self.set_uniform(program, "u_preint_lo", lo)
                self.set_uniform(program, "u_preint_scale", (tex.table.size - 1) / (hi - lo))

    # --- render targets ---

    def target(self, name: str, width: int, height: int, components=(4,)):
        """A framebuffer of float32 textures (one per entry of ``components``), reused while its size fits."""
        entry = self._targets.get(name)
        if entry is None or entry[0][0].size != (width, height) or len(entry[0]) != len(components):
            if entry is not None:
                for t in (*entry[0], entry[1]):
                    t.release()
            textures = [self.ctx.texture((width, height), c, dtype="f4") for c in components]
            entry = (textures, self.ctx.framebuffer(color_attachments=textures))
            self._targets[name] = entry
        return entry

    @staticmethod
    def read(fbo, width: int, height: int, components: int = 4, attachment: int = 0) -> np.ndarray:
        data = np.frombuffer(fbo.read(components=components, dtype="f4", attachment=attachment), dtype=np.float32)
        return data.reshape(height, width, components)[::-1].copy()  # GL rows run bottom up

    def activate(self):
        """Make this renderer's context current (see :func:`make_current`); first in every GL entry point."""
        make_current(self.ctx)

    def close(self):
        self.activate()
        for _, value in self._cache.values():
            _release(value)
        self._cache.clear()
        self.bricks.release()
        for textures, fbo in self._targets.values():
            for t in (*textures, fbo):
                t.release()
        self._targets.clear()
        if self._owns_context:
            release_programs(self.ctx)
            release_context(self.ctx)


class _SubVolume:
    """Enough of a Volume for :func:`upload_volume`: a data array."""

    def __init__(self, data):
        self.data = data


def now() -> float:
    return time.perf_counter()

