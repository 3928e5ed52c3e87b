"""The splatting renderer in GL (see the package doc and ``dvr_gl/renderers/splatting/README.md``).

Per frame: the splats' centres are sorted along the view axis on the host and uploaded in that
order, so that the splats of one slab are one contiguous range (one instanced draw), and
``sheet_buffer = none`` draws them back to front in one draw.  A splat's fragment takes its
pixel's ray into the kernel's voxel space and reads the footprint tables
(``shaders/kernel.glsl``), integrating over the part of the ray inside the box and the
slab.  Coordinates are relative to the box's centre (float32 keeps its precision there).
"""

from __future__ import annotations

import functools
import math

import moderngl
import numpy as np

from ... import limits
from ...clipping import ClipRegion
from ...geometry import chord_lengths
from ...gl.shaders import create_program, shader_root
from ...scene.model import GAUSSIAN_RADIUS
from ...transfer_function import projected_rgba, xray_rgba
from ..base import GLRenderer
from ..grid.classification import classified_voxels, optics_uniforms, shading_defines
from ..grid.tables import check_tables, lookup_table
from ..surfaces import with_surfaces
from . import column, host, low_pass
from .footprint import GaussianFootprint, M4Footprint
from .particles import SUBPIXEL_RADIUS, ParticleSplats
from .sheets import (
    axis_schedule,
    culled_post,
    is_grid,
    kernel_radius,
    kernel_reach,
    kernel_sigma,
    part_voxels,
    pixel_rectangles,
    pre_classified,
    shaded_sheets,
    slab_schedule,
)
from .splats import Splats, ghost_layers, post_visibility
from .work import splat_work

#: GL drivers that shade on the CPU: there particles' X-ray is deposited on the host (:mod:`.column`).
SOFTWARE_GL = ("llvmpipe", "softpipe", "swiftshader")

#: Its own GLSL (before the common library).
SHADERS = (shader_root(__file__),)

# A frame estimated to take longer than this (seconds, at limits.RATES) reports its progress: per sheet, or,
# without sheets, in draws of about this much work (at most MAX_STEPS): Ctrl-C and a sandbox's timer stop it
# between them.
STEP_SECONDS = 0.25
MAX_STEPS = 256


@functools.lru_cache(maxsize=1)
def m4_tables() -> M4Footprint:
    """The M4 tables (float64, 0.8 s to integrate): once per process."""
    return M4Footprint()


class FootprintTextures:
    """The kernel's footprint tables as R32F textures (nearest; the shader interpolates): the Gaussian's
    for a grid, the cubic spline's for particles."""

    def __init__(self, ctx, particles: bool = False, radius_in_sigmas: float = GAUSSIAN_RADIUS):
        """``radius_in_sigmas``: where the Gaussian is cut (``renderer.kernel_radius``; grids only)."""
        if particles:
            m4 = m4_tables()
            tables = (("u_m4_footprint", m4.footprint_table[None, :]),
                      ("u_m4_chord", m4.chord_table), ("u_m4_box", m4.box_table.T),
                      ("u_m4_slab", m4.slab_table[None, :]))
        else:
            gaussian = GaussianFootprint(radius_in_sigmas)
            tables = (("u_footprint", gaussian.footprint_table[None, :]),
                      ("u_cumulative", gaussian.cumulative_table[None, :]))
        self.textures = {}
        for name, table in tables:
            t = ctx.texture((table.shape[1], table.shape[0]), 1, np.ascontiguousarray(table, np.float32).tobytes(),
                            dtype="f4")
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
            t.repeat_x = t.repeat_y = False
            self.textures[name] = t

    def release(self):
        for t in self.textures.values():
            t.release()


class Occlusion:
    """Early termination for sheets composited front to back (Mueller et al.'s occlusion test): before a
    sheet's splats are drawn, those whose screen rectangle (of the bounding sphere, a pixel wider on
    each side) holds no pixel still below ``renderer.ert_threshold`` of accumulated opacity are left
    out, found from a summed-area table of the open pixels; the fragments of the others that land on
    an opaque pixel are discarded (``splat.frag``).  What is dropped reaches only opaque pixels, whose
    remaining transmittance is at most ``1 - threshold``: as the ray caster's early termination."""

    def __init__(self, scene, positions: np.ndarray, radii, attributes):
        self.threshold = scene.renderer.ert_threshold
        i0, i1, j0, j1 = pixel_rectangles(scene, positions, radii)
        w, h = scene.image.width, scene.image.height
        self.rect = (np.clip(i0 - 1, 0, w), np.clip(i1 + 2, 0, w), np.clip(j0 - 1, 0, h), np.clip(j1 + 2, 0, h))
        self.attributes = attributes
        self.scratch = None

    def visible(self, alpha: np.ndarray, first: int, last: int) -> np.ndarray | None:
        """The splats of ``first .. last`` (in upload order) whose rectangle holds an open pixel; None if no
        pixel is open."""
        open_ = alpha < self.threshold
        if not open_.any():
            return None
        if open_.all():
            return np.arange(first, last)
        table = np.zeros((open_.shape[0] + 1, open_.shape[1] + 1), np.int64)
        table[1:, 1:] = np.cumsum(np.cumsum(open_, axis=0), axis=1)
        c0, c1, r0, r1 = (x[first:last] for x in self.rect)  # half-open: columns c0 .. c1 - 1
        count = table[r1, c1] - table[r0, c1] - table[r1, c0] + table[r0, c0]
        return first + np.nonzero(count > 0)[0]

    def subset(self, ctx, program, keep: np.ndarray):
        """A vertex array over only the splats ``keep`` (``(vao, buffers, 0, n)``)."""
        self.release()
        self.scratch = [(name, width, ctx.buffer(np.ascontiguousarray(rows[keep]).tobytes()))
                        for name, width, rows in self.attributes]
        vao = ctx.vertex_array(program, [])
        self.scratch_vao = vao
        return vao, self.scratch, 0, len(keep)

    def release(self):
        if self.scratch:
            for _, _, b in self.scratch:
                b.release()
            self.scratch_vao.release()
        self.scratch = None


class SplattingRenderer(GLRenderer):
    name = "splatting"
    #: Rasterize the frames :func:`.host.serves` on the host (numba, where installed) instead of in GL.
    host_sheets = True
    #: False: particles' X-ray always drawn in GL (the host deposit, :mod:`.column`, is for software GL)
    host_columns = True

    def work(self, scene):
        """Fragments of footprints, instances and sheets (:mod:`.work`), checked before the frame."""
        return splat_work(scene)

    def check_textures(self, scene, gl):
        """The transfer function's table the sheets and culling read (:func:`..grid.tables.check_tables`)."""
        check_tables(scene, gl)

    def _steps(self, scene) -> int:
        """Draws to split an unsheeted frame into, for progress: about :data:`STEP_SECONDS` of estimated
        work each (at most :data:`MAX_STEPS`)."""
        seconds = limits.estimated_seconds(splat_work(scene))
        return int(min(MAX_STEPS, max(1, math.ceil(seconds / STEP_SECONDS))))

    def draw(self, scene) -> np.ndarray:
        """The frame; with ``[[renderer.geometry]]`` the meshes are drawn first (:mod:`..surfaces`),
        every ray's parts end at them, and the sheets are composited over them."""
        return with_surfaces(self, scene, self._draw_volume)

    def _draw_volume(self, scene, surfaces: dict) -> np.ndarray:
        self.activate()
        self._surfaces = surfaces  # u_geometry for every pass, or nothing
        r, field, cam = scene.renderer, scene.field, scene.camera
        lo, hi = (np.asarray(b, float) for b in field.bounds)
        centre = 0.5 * (lo + hi)
        pre = pre_classified(scene)
        if is_grid(scene):
            radius = kernel_reach(scene)
            culling = culled_post(scene)
            splats = self._cached("splats", (field, radius, pre, scene.transfer_function if pre or culling else None,
                                             culling and (r.lut_size, part_voxels(scene))),
                                  lambda: Splats(field, radius, centre, classified_voxels(self, scene) if pre else None,
                                                 self._visibility(scene) if culling else None))
        else:
            splats = self._cached("splats", (field, pre, scene.transfer_function if pre else None),
                                  lambda: ParticleSplats(field, centre, scene.transfer_function.classify_voxels(
                                      field.samples, True) if pre else None))
        forward, right, up = cam.basis()
        eye = np.asarray(cam.eye, float) - centre
        mode = r.compositing
        if self.host_sheets and is_grid(scene) and len(splats) and host.serves(scene) and host.compiled() is not None:
            self.stats.update(splats=len(splats), splats_total=splats.total, culled=splats.total - len(splats))
            image, stats = host.render(scene, splats, centre, lookup_table(self, scene).lut,
                                       report=self.report if self._steps(scene) > 1 else None)
            self.stats.update(stats)
            return image
        if self.host_columns and column.applies(scene, self._software_gl()):
            image = column.host_xray(scene, splats, eye, (forward, right, up), m4_tables())
            if image is not None:
                self.stats.update(splats=len(splats), splats_total=splats.total, culled=splats.total - len(splats),
                                  sheets=0, host=True)
                return image
        if mode == "average" or (mode == "xray" and pre):  # sums: one pass, in any order
            order, schedule = np.arange(len(splats)), None
        elif r.sheet_buffer == "none":
            order, schedule = np.argsort(-splats.depths(eye, forward), kind="stable"), None  # back to front
        elif r.sheet_buffer == "axis_aligned":
            order, schedule = axis_schedule(scene, splats, centre)
        else:
            reach = None if is_grid(scene) else splats.reach
            order, schedule = slab_schedule(scene, splats.depths(eye, forward), reach)
        self.stats.update(splats=len(splats), splats_total=splats.total, culled=splats.total - len(splats))
        if not len(splats):  # pre-classified, every voxel transparent
            return np.zeros((scene.image.height, scene.image.width, 4), np.float32)
        attributes = splats.attributes(order)
        buffers = [(name, width, self.ctx.buffer(rows.tobytes())) for name, width, rows in attributes]
        occlusion = None
        if (schedule is not None and mode == "emission_absorption" and r.ert_threshold < 1.0
                and not shaded_sheets(scene)):
            occlusion = Occlusion(scene, splats.positions[order] + centre, splats.bounding_radii(), attributes)
        try:
            return self._composite(scene, buffers, schedule, centre, eye, (forward, right, up), occlusion)
        finally:
            for _, _, b in buffers:
                b.release()

    def _software_gl(self) -> bool:
        """Whether the context's driver shades on the CPU (asked once: ``ctx.info`` takes 20 ms)."""
        if getattr(self, "_software", None) is None:
            info = self.ctx.info.get("GL_RENDERER", "").lower()
            self._software = any(name in info for name in SOFTWARE_GL)
        return self._software

    def _visibility(self, scene):
        r, tf = scene.renderer, scene.transfer_function
        lo, hi = lookup_table(self, scene).lut.domain
        radius = kernel_reach(scene)
        return post_visibility(scene.volume, tf, radius, kernel_sigma(scene), (hi - lo) / (r.lut_size - 1),
                               ghost_layers(radius), part_voxels(scene))

    # --- passes ---

    def _defines(self, scene, **extra) -> dict:
        defines = {"CLASSIFY_PRE": pre_classified(scene), "CULLING": culled_post(scene),
                   "FOOTPRINT_EWA": scene.renderer.footprint == "ewa", **extra}
        if not is_grid(scene):
            defines.update(PARTICLES=True, SUBPIXEL_RADIUS=f"{SUBPIXEL_RADIUS:.1f}")
        elif scene.renderer.filter == "cubic_bspline":
            defines["KERNEL_BSPLINE"] = True
        if scene.camera.projection == "orthographic":
            defines["CAMERA_ORTHOGRAPHIC"] = True
        defines["GEOMETRY"] = bool(getattr(scene.renderer, "geometry", None))
        defines = {k: v for k, v in defines.items() if v}
        clip = ClipRegion.of(scene.renderer)
        if clip is not None:  # NUM_CLIP_PLANES may be 0: kept
            defines.update({k: v for k, v in clip.defines().items() if v is not False})
        return defines

    def _uniforms(self, scene, centre, eye, basis) -> dict:
        r, field, img, cam = scene.renderer, scene.field, scene.image, scene.camera
        forward, right, up = basis
        lo, hi = (np.asarray(b, float) - centre for b in field.bounds)
        u = {"u_eye": tuple(eye), "u_forward": tuple(forward), "u_right": tuple(right), "u_up": tuple(up),
             "u_half_extent": cam.half_extent(img.width / img.height), "u_image_size": (img.width, img.height),
             "u_near": cam.near, "u_box_lo": tuple(lo), "u_box_hi": tuple(hi)}
        if is_grid(scene):
            u.update(u_spacing=tuple(field.spacing), u_radius=kernel_radius(scene), u_sigma=r.kernel_width,
                     u_sigmas=r.kernel_radius, u_low_pass=r.screen_low_pass)
        clip = ClipRegion.of(r)
        if clip is not None:  # in the shaders' coordinates: relative to the box's centre
            u.update(clip.shifted(centre).uniforms())
        return u

    def _splat_program(self, scene, **extra):
        # the low-pass widens the splats' kernels only (the sheets read what they summed)
        low = is_grid(scene) and scene.renderer.filter == "gaussian" and low_pass.enabled(scene)
        return create_program(self.ctx, "splat.vert", "splat.frag",
                              self._defines(scene, LOW_PASS=low, **extra), roots=SHADERS)

    def _splat_vao(self, program, buffers):
        vao = self.ctx.vertex_array(program, [])
        self._bind_splats(vao, program, buffers, 0)
        return vao

    @staticmethod
    def _bind_splats(vao, program, buffers, first: int):
        """The instance attributes (``(name, floats, buffer)``) from splat ``first`` on."""
        for name, width, buf in buffers:
            if name in program:
                vao.bind(program[name].location, "f", buf, f"{width}f", offset=4 * width * first, divisor=1)

    def _draw_splats(self, vao, program, buffers, first: int, count: int):
        self._bind_splats(vao, program, buffers, first)
        vao.render(moderngl.TRIANGLE_STRIP, vertices=4, instances=count)

    def _composite(self, scene, buffers, schedule, centre, eye, basis, occlusion=None) -> np.ndarray:
        r, img = scene.renderer, scene.image
        w, h = img.width, img.height
        uniforms = self._uniforms(scene, centre, eye, basis)
        particles = not is_grid(scene)
        radius = None if particles else r.kernel_radius
        tables = self._cached("footprint tables", (particles, radius),
                              lambda: FootprintTextures(self.ctx, particles, radius or GAUSSIAN_RADIUS))
        textures = {**tables.textures, **self._surfaces}
        ctx = self.ctx
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        count = buffers[0][2].size // 16
        if schedule is None:
            over = r.compositing == "emission_absorption"
            program = self._splat_program(scene, SPLAT_OVER=over)
            self.bind(program, uniforms, textures)
            _, fbo = self.target("accumulation", w, h)
            fbo.use()
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA) if over else (moderngl.ONE, moderngl.ONE)
            vao = self._splat_vao(program, buffers)
            steps = self._steps(scene) if count else 0
            edges = np.linspace(0, count, steps + 1).round().astype(int)
            for step, (a, b) in enumerate(zip(edges[:-1], edges[1:])):  # in upload order: the back-to-front order kept
                if b > a:
                    self._draw_splats(vao, program, buffers, int(a), int(b - a))
                if steps > 1:
                    ctx.finish()
                    self.report(step + 1, steps)
            vao.release()
            ctx.disable(moderngl.BLEND)
            image = self.read(fbo, w, h).astype(np.float64)
            self.stats["sheets"] = 0
            if r.compositing == "xray":
                image = _radiograph(image)
            elif not over:
                image = self._average(scene, image)
            return image.astype(np.float32)
        sheets_kind = "SLABS" if r.sheet_buffer == "image_aligned" else "AXIS_SHEETS"
        # renderer.slabs_per_draw: a group of slabs drawn at once, a target each (GL guarantees 8 draw buffers);
        # shaded sheets are drawn one by one (each waits for the one behind it)
        grouped = sheets_kind == "SLABS" and not shaded_sheets(scene) and r.slabs_per_draw > 1
        program = self._splat_program(scene, SLABS=sheets_kind == "SLABS", ERT=occlusion is not None,
                                      SLAB_GROUP=r.slabs_per_draw if grouped else 0)
        xray = r.compositing == "xray"
        shaded = shaded_sheets(scene)
        sheet_defines = self._defines(scene, **{sheets_kind: True, "XRAY": xray})
        if shaded:
            shading_defines(scene, sheet_defines)
        sheet_program = create_program(ctx, "fullscreen.vert", "sheet.frag", sheet_defines, roots=SHADERS)
        lut = lookup_table(self, scene)
        sheet_uniforms = {**uniforms, **{k: v for k, v in optics_uniforms(scene, lut.lut).items()
                                         if shaded or k.startswith("u_lut")}}
        # shaded, a sheet is composited once the one behind it is drawn (its gradient along the view): a ring
        # of three sheets, and a cleared one standing for the slabs beyond the first and the last
        ring = [self.target(f"sheet {i}" if shaded else "sheet", w, h) for i in range(3 if shaded else 1)]
        if shaded:
            (empty,), empty_fbo = self.target("sheet empty", w, h)
            empty_fbo.use()
            empty_fbo.clear(0.0, 0.0, 0.0, 0.0)
        (accumulated,), accumulation = self.target("accumulation", w, h)
        accumulation.use()
        accumulation.clear(0.0, 0.0, 0.0, 0.0)
        vao = self._splat_vao(program, buffers)
        quad = ctx.vertex_array(sheet_program, [])
        pre = pre_classified(scene)
        drawn = skipped = 0
        sheet_count = len(schedule)
        if occlusion is not None:
            textures = {**textures, "u_accumulated": accumulated}
            uniforms = {**uniforms, "u_ert": r.ert_threshold}

        def composite(index: int, texture=None):
            """Sheet ``index`` (in ``texture``, or the ring's) under what lies in front of it."""
            accumulation.use()
            ctx.enable(moderngl.BLEND)
            # under, front to back; the X-ray adds its sheets' optical depth and emission
            ctx.blend_func = (moderngl.ONE, moderngl.ONE) if xray else (moderngl.ONE_MINUS_DST_ALPHA, moderngl.ONE)
            sheets = {"u_sheet": texture or ring[index % len(ring)][0][0]}
            if shaded:
                sheets.update(u_sheet_prev=ring[(index - 1) % 3][0][0] if index > 0 else empty,
                              u_sheet_next=ring[(index + 1) % 3][0][0] if index + 1 < len(schedule) else empty)
            self.bind(sheet_program, {**sheet_uniforms, **schedule[index][0]},
                      {**sheets, "u_lut": lut.texture, **self._surfaces})
            quad.render(moderngl.TRIANGLES, vertices=3)

        size = r.slabs_per_draw if grouped else 1  # slabs drawn at once
        long_frame = self._steps(scene) > 1

        def progress(done: int):
            """A long frame tells its sheets' progress (and stops there at Ctrl-C or the time limit)."""
            if long_frame:
                ctx.finish()
                self.report(done, sheet_count)
        if grouped:
            group_textures, group_fbo = self.target("sheet group", w, h, components=(4,) * size)
        try:
            for start in range(0, len(schedule), size):
                group = schedule[start:start + size]
                first, last = group[0][1], max(b for _, _, b in group)
                n = last - first
                if n <= 0 and pre:
                    continue  # nothing in these sheets: transparent
                draw = self._unoccluded(occlusion, accumulation, program, vao, buffers, first, n)
                if draw is None:  # every pixel opaque: nothing behind counts
                    skipped += sum(max(b - a, 0) for _, a, b in schedule[start:])
                    break
                skipped += n - draw[3]
                if grouped:  # each splat's part of every slab of the group, a target each
                    bounds = [group[0][0]["u_slab"][0]] + [sheet["u_slab"][1] for sheet, _, _ in group]
                    bounds += [bounds[-1]] * (size + 1 - len(bounds))  # a short last group: empty slabs
                    drawn += self._fill(group_fbo, program, {**uniforms, "u_slab": (bounds[0], bounds[-1]),
                                                             "u_group": bounds}, textures, draw)
                    for offset in range(len(group)):
                        composite(start + offset, group_textures[offset])
                    progress(start + len(group))
                    continue
                drawn += self._fill(ring[start % len(ring)][1], program, {**uniforms, **group[0][0]}, textures, draw)
                if not shaded:
                    composite(start)
                elif start > 0:
                    composite(start - 1)
                progress(start + 1)
            if shaded and schedule:
                composite(len(schedule) - 1)
        finally:
            ctx.disable(moderngl.BLEND)
            vao.release()
            quad.release()
            if occlusion is not None:
                occlusion.release()
        self.stats.update(sheets=sheet_count, splats_drawn=drawn, skipped=skipped)
        image = self.read(accumulation, w, h)
        return _radiograph(image).astype(np.float32) if xray else image

    def _unoccluded(self, occlusion, accumulation, program, vao, buffers, first: int, n: int):
        """What to draw of the ``n`` splats from ``first``: ``(vao, buffers, first, count)``, without those
        behind opaque pixels (early termination); None if every pixel is opaque."""
        if occlusion is None or n <= 0:
            return vao, buffers, first, max(n, 0)
        w, h = accumulation.size
        keep = occlusion.visible(self.read(accumulation, w, h)[..., 3], first, first + n)
        if keep is None:
            return None
        if 0 < len(keep) < n:
            return occlusion.subset(self.ctx, program, keep)
        return vao, buffers, first, len(keep)

    def _fill(self, fbo, program, uniforms, textures, draw) -> int:
        """Clear the sheet target ``fbo`` and add ``draw``'s splats to it; the instances drawn."""
        ctx = self.ctx
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = (moderngl.ONE, moderngl.ONE)
        vao, buffers, first, count = draw
        if count > 0:
            self.bind(program, uniforms, textures)
            self._draw_splats(vao, program, buffers, first, count)
        return count

    @staticmethod
    def _average(scene, image) -> np.ndarray:
        """The sum of the splats' integrals (``.r``) over each ray's chord in the box, classified as the
        references classify an average."""
        length = chord_lengths(scene)
        hit = length > 0
        out = np.zeros(image.shape)
        out[hit] = projected_rgba(scene.transfer_function, image[..., 0][hit] / length[hit])
        return out


def _radiograph(image: np.ndarray) -> np.ndarray:
    """The X-ray's image from its sums ``(sigma c, sigma)`` per pixel (float64)."""
    sums = image.reshape(-1, 4).astype(np.float64)
    return xray_rgba(sums[:, :3], sums[:, 3]).reshape(image.shape)
