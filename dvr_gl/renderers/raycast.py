"""GPU ray casting: one GLSL fragment loop per pixel (``shaders/raycast.frag``).

The scene decides the program: :func:`shader_features` turns it into defines
(compositing mode, filter, classification, shading, jitter, early termination,
...), so a feature the scene does not use is not compiled, computed or
uploaded; programs are cached per feature set.  Textures are cached per
volume and transfer function, so an orbit or a transfer-function edit
uploads only what changed.  The result is read back from a float32 RGBA
target: premultiplied, linear, background not applied.
"""

from __future__ import annotations

import math
import time

import moderngl
import numpy as np

from .. import acceleration as accel
from ..acceleration import level_count
from ..gl.context import create_context
from ..gl.shaders import create_program, release_programs
from ..preintegration import preintegrate
from ..gl.textures import (central_difference_gradients, check_fits, upload_field, upload_table,
                           upload_volume, volume_bytes)
from .base import Renderer

COMPOSITING = {"emission_absorption": "COMPOSITE_EMISSION", "isosurface": "COMPOSITE_ISOSURFACE",
               "average": "COMPOSITE_AVERAGE", "mip": "COMPOSITE_MIP", "minip": "COMPOSITE_MINIP"}
FILTER = {"nearest": "FILTER_NEAREST", "linear": "FILTER_LINEAR", "cubic_bspline": "FILTER_CUBIC_BSPLINE",
          "catmull_rom": "FILTER_CATMULL_ROM"}


def shader_features(scene, count_samples: bool = False) -> dict:
    """The defines for exactly the features this scene uses."""
    r = scene.renderer
    emission = r.compositing == "emission_absorption"
    defines = {COMPOSITING[r.compositing]: True, FILTER[r.filter]: True}
    if r.filtering == "shader" and r.filter != "nearest":
        defines["FILTER_IN_SHADER"] = True
    if scene.camera.projection == "orthographic":
        defines["CAMERA_ORTHOGRAPHIC"] = True
    if emission:
        defines["BACK_TO_FRONT"] = r.order == "back_to_front"
        defines["EARLY_TERMINATION"] = r.order == "front_to_back" and r.ert_threshold < 1.0
        defines["CLASSIFY_PRE"] = r.classification == "pre"
        defines["CLASSIFY_PREINTEGRATED"] = r.classification == "preintegrated"
        defines["ASSOCIATED_COLORS"] = r.classification == "pre" and r.associated_colors
        defines["GRADIENT_OPACITY"] = r.gradient_opacity
    shaded = r.shading.enabled and (emission or r.compositing == "isosurface")
    if shaded and r.shading.lights:
        defines.update(SHADING=True, NUM_LIGHTS=len(r.shading.lights), TWO_SIDED=r.shading.two_sided)
    if defines.get("SHADING") or defines.get("GRADIENT_OPACITY"):
        defines["GRADIENT_TEXTURE"] = r.gradient == "texture"
    defines["JITTER"] = r.jitter
    if r.acceleration and r.compositing != "average":  # every sample counts in an average
        defines.update(ACCELERATE=True, NUM_LEVELS=level_count(scene.volume.dims, r.block_size))
    defines["COUNT_SAMPLES"] = count_samples
    return {k: v for k, v in defines.items() if v is not False}


def _same(a, b) -> bool:
    if a is b:
        return True
    plain = (int, float, str, bool, type(None))
    return isinstance(a, plain) and isinstance(b, plain) and a == b


def _release(value):
    """Release what a cache entry holds on the GPU (pyramids hold nothing)."""
    target = getattr(value, "texture", value)
    if hasattr(target, "release"):
        target.release()


class BlockTextures(list):
    """One nearest-filtered float texture per pyramid level (releases them together)."""

    def __init__(self, ctx, levels: list[np.ndarray]):
        super().__init__(upload_field(ctx, a) for a in levels)
        for tex in self:
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def release(self):
        for tex in self:
            tex.release()


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


class RayCastRenderer(Renderer):
    name = "raycast"
    description = "GPU ray casting in a GLSL fragment loop"

    def __init__(self, ctx=None, count_samples: bool = False, fragment_shader: str = "raycast.frag"):
        """``ctx``: a moderngl context to render with (default: a new headless EGL context).
        ``count_samples``: also record the samples each ray takes (for benchmarks).
        ``fragment_shader``: another program with the same uniforms (benchmarks compare one)."""
        super().__init__()
        self.ctx = ctx or create_context()
        self._owns_context = ctx is None
        self.count_samples = count_samples
        self.fragment_shader = fragment_shader
        self._cache: dict = {}   # what -> (key objects, texture or host data)
        self._targets = None

    # --- textures, cached by identity of what they were made from ---

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

    def _textures(self, scene, defines) -> dict:
        r, volume, tf = scene.renderer, scene.volume, scene.transfer_function
        needs_classified = "CLASSIFY_PRE" in defines
        needs_gradient = "GRADIENT_TEXTURE" in defines
        nbytes = volume_bytes(volume) + (16 * volume.data.size if needs_classified else 0) \
            + (12 * volume.data.size if needs_gradient else 0)
        what = "the volume" + (", its classified copy" if needs_classified else "") \
            + (" and its gradients" if needs_gradient else "")
        check_fits(self.ctx, volume, nbytes, r.texture_budget_mb, what)
        out = {"u_volume": self._cached("volume", (volume,), lambda: upload_volume(self.ctx, volume))}
        out["u_lut"] = self._cached("lut", (tf, r.lut_size), lambda: TableTexture(self.ctx, tf.tabulate(r.lut_size)))
        if needs_classified:
            voxels = self._classified_voxels(scene)
            out["u_classified"] = self._cached("classified", (voxels,), lambda: upload_field(self.ctx, voxels))
        if needs_gradient:
            out["u_gradient"] = self._cached("gradient", (volume,),
                                             lambda: upload_field(self.ctx, central_difference_gradients(volume)))
        if "CLASSIFY_PREINTEGRATED" in defines:
            out["u_preint"] = self._cached(
                "preintegration", (tf, r.sample_distance, r.preintegration_size, r.preintegration, r.lut_size),
                lambda: PreintegrationTexture(self.ctx, preintegrate(tf, r.sample_distance, r.preintegration_size,
                                                                     r.preintegration, r.lut_size)))
        if "ACCELERATE" in defines:
            preint = out["u_preint"].table if "u_preint" in out else None
            for level, tex in enumerate(self._block_textures(scene, defines, out["u_lut"].lut, preint)):
                out[f"u_blocks{level}"] = tex
        return out

    def _classified_voxels(self, scene) -> np.ndarray:
        """Pre-classified voxels (float32), shared by their texture and their block classes."""
        r, volume, tf = scene.renderer, scene.volume, scene.transfer_function
        return self._cached("classified voxels", (volume, tf, r.associated_colors),
                            lambda: tf.classify_voxels(volume.data, r.associated_colors).astype(np.float32))

    def _block_textures(self, scene, defines, lut, preint=None) -> list:
        """Per-level block textures for this mode (see dvr_gl.acceleration), cached by what they depend on."""
        r, volume = scene.renderer, scene.volume
        support = accel.SUPPORT[r.filter]
        if "CLASSIFY_PRE" in defines:
            voxels = self._classified_voxels(scene)
            pyramids = self._cached("pyramid", (voxels, support, r.block_size), lambda: [
                accel.MinMaxPyramid.build(voxels[..., c], r.block_size, support) for c in range(4)])
        else:
            pyramids = self._cached("pyramid", (volume, support, r.block_size),
                                    lambda: accel.MinMaxPyramid.build(volume.data, r.block_size, support))
        if "COMPOSITE_EMISSION" not in defines:
            return self._cached("blocks", ("minmax", pyramids, r.filter), lambda: BlockTextures(
                self.ctx, accel.minmax_textures(pyramids, r.filter)))
        # Shaded colours differ at every sample, and pre-integrated segments see the table's own
        # values: only empty blocks are jumped then (exactly zero in both).
        constant_allowed = not ("SHADING" in defines or "GRADIENT_OPACITY" in defines or preint is not None)
        snap = (preint.domain, preint.size) if preint is not None else None
        if preint is not None:
            lut = preint.source
        if "CLASSIFY_PRE" in defines:
            make = lambda: accel.classified_classes(pyramids, r.associated_colors, r.filter,  # noqa: E731
                                                    volume.spacing, r.homogeneity_tolerance, constant_allowed)
        else:
            make = lambda: accel.table_classes(pyramids, lut, r.filter, volume.spacing,  # noqa: E731
                                               r.homogeneity_tolerance, constant_allowed, snap)
        key = ("classes", pyramids, lut, r.filter, r.homogeneity_tolerance, constant_allowed, snap)
        return self._cached("blocks", key, lambda: BlockTextures(self.ctx, make()))

    # --- uniforms ---

    @staticmethod
    def _uniforms(scene, lut) -> dict:
        r, cam, vol, img = scene.renderer, scene.camera, scene.volume, scene.image
        f, right, up = cam.basis()
        aspect = img.width / img.height
        if cam.projection == "perspective":
            h = math.tan(math.radians(cam.fov) / 2.0)
            half = (h * aspect, h)
        else:
            half = (cam.view_height / 2.0 * aspect, cam.view_height / 2.0)
        lo, hi = vol.box
        spacing = np.array(vol.spacing)
        tf = scene.transfer_function
        lut_lo, lut_hi = lut.domain
        ert = r.ert_threshold
        u = {
            "u_eye": cam.eye, "u_forward": f, "u_right": right, "u_up": up, "u_half_extent": half,
            "u_image_size": (img.width, img.height), "u_near": cam.near,
            "u_box_lo": lo, "u_box_hi": hi, "u_world_to_voxel_scale": 1.0 / spacing,
            "u_world_to_voxel_offset": -np.array(vol.origin) / spacing, "u_voxel_spacing": spacing,
            "u_dims": vol.dims, "u_sample_distance": r.sample_distance,
            "u_unit_distance": tf.unit_distance, "u_iso_value": r.iso_value, "u_iso_steps": r.iso_refinement,
            "u_ert_depth": -math.log1p(-ert) if ert < 1.0 else 3.0e38,
            "u_gradient_reference": r.gradient_opacity_reference,
            "u_lut_size": r.lut_size, "u_lut_lo": lut_lo, "u_lut_scale": (r.lut_size - 1) / (lut_hi - lut_lo),
            "u_jitter_seed": r.jitter_seed % 2 ** 32, "u_block_size": r.block_size,
            "u_ambient": r.shading.ambient, "u_diffuse": r.shading.diffuse, "u_specular": r.shading.specular,
            "u_shininess": r.shading.shininess, "u_gradient_epsilon": vol.gradient_epsilon,
        }
        lights = r.shading.lights
        if lights:
            u["u_light_dir"] = [(0.0, 0.0, 0.0, 1.0) if l.type == "headlight" else
                                (*(-np.asarray(l.direction) / np.linalg.norm(l.direction)), 0.0) for l in lights]
            u["u_light_color"] = [tuple(l.color) for l in lights]
        return u

    @staticmethod
    def _set(program, name, value):
        if name not in program:
            return  # unused by this feature set: compiled out
        uniform = program[name]
        if isinstance(value, list):  # a uniform array: write its packed float32 values
            uniform.write(np.asarray(value, dtype=np.float32).tobytes())
        elif isinstance(value, (tuple, list, np.ndarray)):
            uniform.value = tuple(int(x) if uniform.fmt.endswith("i") else float(x) for x in value)
        else:
            uniform.value = value

    # --- rendering ---

    def _framebuffer(self, width: int, height: int):
        if self._targets is None or self._targets[0].size != (width, height) or \
                (len(self._targets) > 2) != self.count_samples:
            if self._targets:
                for t in self._targets:
                    t.release()
            colour = self.ctx.texture((width, height), 4, dtype="f4")
            attachments = [colour]
            if self.count_samples:
                attachments.append(self.ctx.texture((width, height), 2, dtype="f4"))
            fbo = self.ctx.framebuffer(color_attachments=attachments)
            self._targets = (*attachments, fbo)
        return self._targets

    def render(self, scene) -> np.ndarray:
        start = time.perf_counter()
        defines = shader_features(scene, self.count_samples)
        program = create_program(self.ctx, "fullscreen.vert", self.fragment_shader, defines)
        textures = self._textures(scene, defines)
        for name, value in self._uniforms(scene, textures["u_lut"].lut).items():
            self._set(program, name, value)
        for unit, (name, tex) in enumerate(textures.items()):
            getattr(tex, "texture", tex).use(location=unit)
            self._set(program, name, unit)
            if name == "u_volume":
                self._set(program, "u_value_scale", tex.value_scale)
                self._set(program, "u_value_offset", tex.value_offset)
            if name == "u_preint":
                lo, hi = tex.table.domain
                self._set(program, "u_preint_size", tex.table.size)
                self._set(program, "u_preint_lo", lo)
                self._set(program, "u_preint_scale", (tex.table.size - 1) / (hi - lo))
        width, height = scene.image.width, scene.image.height
        *attachments, fbo = self._framebuffer(width, height)
        fbo.use()
        self.ctx.viewport = (0, 0, width, height)
        self.ctx.disable(self.ctx.BLEND | self.ctx.DEPTH_TEST)
        vao = self.ctx.vertex_array(program, [])
        try:
            drawn = time.perf_counter()
            vao.render(mode=self.ctx.TRIANGLES, vertices=3)
            self.ctx.finish()
            gpu_seconds = time.perf_counter() - drawn
            data = np.frombuffer(fbo.read(components=4, dtype="f4", attachment=0), dtype=np.float32)
            image = data.reshape(height, width, 4)[::-1].copy()  # GL rows run bottom up
            self.stats = {"seconds": time.perf_counter() - start, "gpu_seconds": gpu_seconds, "defines": defines}
            if self.count_samples:
                counts = np.frombuffer(fbo.read(components=2, dtype="f4", attachment=1), dtype=np.float32)
                samples, jumps = counts[0::2], counts[1::2]
                hit = (samples + jumps) > 0
                self.stats["samples"] = int(samples.sum(dtype=np.float64))
                self.stats["samples_per_ray"] = float(samples[hit].mean()) if hit.any() else 0.0
                self.stats["jumps_per_ray"] = float(jumps[hit].mean()) if hit.any() else 0.0
        finally:
            vao.release()
        return image

    def close(self):
        for _, value in self._cache.values():
            _release(value)
        self._cache.clear()
        if self._targets:
            for t in self._targets:
                t.release()
            self._targets = None
        if self._owns_context:
            release_programs(self.ctx)
            self.ctx.release()
