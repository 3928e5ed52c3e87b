"""Single scattering on the GPU: the defines and uniforms of ``shaders/common/scattering.glsl``, and the
light volume's pass (``shaders/scattering/light_volume.frag``), the GLSL this module sits beside.

The light volume holds each light's optical depth at the nodes of a grid over the field's box
(:func:`dvr_gl.reference.scattering.light_volume_dims`, the CPU reference's same grid); a frame's
samples interpolate it instead of marching a shadow ray each.  It belongs to scattering, not to a
renderer: the pass marches the field through whatever sampling the calling renderer binds (its
textures and uniforms, made by the grid sampling kit, :mod:`dvr_gl.renderers.grid.sampling`), on the
renderer's :class:`~dvr_gl.gl.frame.GLFrame`.  Half-angle slicing's light buffer
(``scattering/light_slice.frag``) is the slicers' own (:mod:`dvr_gl.renderers.grid.slicing`).
"""

from __future__ import annotations

import time

import moderngl
import numpy as np

from ..reference.scattering import light_volume_dims
from ..scene.settings import albedo_column, constant_albedo, shadow_step
from .shaders import create_program

# The frame's defines the light volume's pass keeps (besides the filter's): what its shadow rays'
# samples classify with, and the lights.
PASS_KEYS = ("CLASSIFY_PRE", "ASSOCIATED_COLORS", "GRADIENT_OPACITY", "GRADIENT_TEXTURE", "SCATTERING",
             "NUM_SCATTER_LIGHTS", "PHASE_HG")


def scattering_defines(scene, defines: dict):
    """Single scattering (``common/scattering.glsl``) into ``defines``, only where the scene enables it
    (emission-absorption): the lights, the phase function, the shadows' method, the albedo's column."""
    sc = getattr(scene.renderer, "scattering", None)
    if sc is None or not sc.enabled or scene.renderer.compositing != "emission_absorption":
        return
    defines.update(SCATTERING=True, NUM_SCATTER_LIGHTS=len(sc.lights), PHASE_HG=sc.phase == "henyey_greenstein",
                   SHADOWS=sc.shadows and sc.method == "shadow_rays",
                   LIGHT_VOLUME=sc.shadows and sc.method == "light_volume",
                   HALF_ANGLE=sc.shadows and sc.method == "half_angle",
                   ALBEDO_TABLE=albedo_column(scene.renderer, scene.transfer_function))


def light_volume_pass_defines(defines: dict) -> dict:
    """The light volume's pass: the frame's filtering and classification defines (the extinction its
    samples see; a pre-integrated frame's shadow rays classify points, post) and its lights, marching
    shadow rays."""
    keep = {k: v for k, v in defines.items() if k in PASS_KEYS or k.startswith("FILTER")}
    return {**keep, "SHADOWS": True}


def scattering_uniforms(scene) -> dict:
    """The lights of single scattering: toward a directional light (w 0) or a point light's position
    (w 1), irradiance, albedo, phase, the shadow rays' step (the sample distance, world units) and the
    nearest a point light counts as (half the smallest voxel, as :mod:`dvr_gl.reference.scattering`)."""
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


def light_volume_key(scene, pass_defines: dict) -> tuple:
    """What a light volume depends on (a cache key: :func:`dvr_gl.gl.frame.same_key`): the volume, the
    transfer function, the lights, the grid's size, the shadow rays' step and classification."""
    r = scene.renderer
    return (scene.volume, scene.transfer_function, repr(r.scattering.lights), r.scattering.light_volume_size,
            shadow_step(r, scene.field), repr(sorted(pass_defines.items())), r.lut_size,
            r.gradient_opacity_reference, r.kernel_width, r.kernel_radius)


class LightVolumeTexture:
    """Each light's optical depth at the light volume's nodes (a 32-bit float 3D texture with a channel
    per light, nearest; the shaders interpolate), marched by ``scattering/light_volume.frag`` in slabs
    of nodes on ``frame`` (a :class:`~dvr_gl.gl.frame.GLFrame`) with ``textures`` and ``uniforms``, the
    field's sampling and classification as the frame binds them; ``seconds``: what making it took since
    ``started`` (perf_counter seconds; default: now), the recomputation a light or transfer-function
    change costs."""

    MAX_ROWS = 8192  # a pass's target height: within every GL's texture limit

    def __init__(self, frame, scene, defines: dict, textures: dict, uniforms: dict, started: float | None = None):
        start = time.perf_counter() if started is None else started
        ctx = frame.ctx
        lo, hi = scene.field.bounds
        nx, ny, nz = self.dims = light_volume_dims(lo, hi, scene.renderer.scattering.light_volume_size)
        program = create_program(ctx, "fullscreen.vert", "scattering/light_volume.frag", defines)
        uniforms = {**uniforms, "u_box_lo": lo, "u_box_hi": hi, "u_nodes": self.dims}
        slabs = max(1, self.MAX_ROWS // ny)
        depths = []
        vao = ctx.vertex_array(program, [])
        try:
            for first in range(0, nz, slabs):
                count = min(slabs, nz - first)
                frame.bind(program, {**uniforms, "u_first_k": first}, textures)
                (_,), fbo = frame.target("light volume", nx, ny * count)
                fbo.use()
                ctx.viewport = (0, 0, nx, ny * count)
                ctx.disable(ctx.BLEND | ctx.DEPTH_TEST)
                vao.render(mode=ctx.TRIANGLES, vertices=3)  # fullscreen.vert's one triangle
                depths.append(frame.read(fbo, nx, ny * count, flip=False))  # node rows bottom up, as drawn
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
