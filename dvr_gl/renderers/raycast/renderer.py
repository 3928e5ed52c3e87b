"""GPU ray casting: one GLSL fragment loop per pixel (``shaders/raycast.frag``).

The scene decides the program: :func:`shader_features` turns it into defines
(compositing mode, filter, classification, shading, jitter, early termination,
acceleration), so a feature the scene does not use is not compiled, computed
or uploaded; programs are cached per feature set, textures per what they were
made from (:mod:`dvr_gl.gl.frame`).  It samples the grid through the grid kit
(:mod:`..grid.sampling`).  A volume beyond the GL texture limit or the
texture budget is rendered in bricks: one pass per brick, front to back (back
to front for that order), each continuing the compositing state of the last,
so the image is the one a single texture would give.
"""

from __future__ import annotations

import dataclasses
import math
from time import perf_counter as now

import moderngl
import numpy as np

from ... import limits
from ... import rays as rays_mod
from ...errors import SceneError
from ...fields import diagonal
from ...gl.frame import same_key
from ...gl.geometry import gl_matrix, projection_matrix, view_matrix
from ...gl.shaders import create_program, shader_root
from ...orientation import volume_frame_scene
from ...scene.settings import shadow_step
from ...transfer_function_2d import is_2d
from ..grid.bricking import ghost_width, plan_bricks, visibility_order
from ..grid.classification import classification_features
from ..grid.sampling import GridRenderer
from ..grid.textures import texel_bytes, upload_field
from ..grid.views import GridView
from ..surfaces import with_surfaces
from . import acceleration as accel
from . import out_of_core, ray_bounds
from .acceleration import level_count
from .fields import draw_fields
from .ray_bounds import BoundsFaces, box_rectangle

#: The ray caster's own GLSL (before the common library).
SHADERS = (shader_root(__file__),)

# A one-pass frame estimated to take longer than this (seconds, at limits.RATES) is drawn in bands of
# about this much work: the progress bar moves, and Ctrl-C or a sandbox's timer stop it between bands.
BAND_SECONDS = 0.25

# renderer.acceleration = "auto" skips blocks where the frame's estimated skippable fraction of samples
# (acceleration.skip_estimate) is at least AUTO_MIN_SKIPPABLE (below it, the jumps' divergence costs
# more than they save) and the estimated cost with skipping, the samples kept plus LOOKUP_COST samples
# per estimated block lookup, is below the samples without: at large sample distances a jump saves
# few samples and costs its lookup all the same (docs/acceleration.md, "Auto").
AUTO_MIN_SKIPPABLE = 0.2
# A block lookup's cost in samples, per mode (skip_estimate's): chosen from the break-even costs
# that benchmarks/auto_skipping.py measures on llvmpipe (skipping on against off at 0.5 to 8 voxels on
# Marschner-Lobb, blobs, CThead, the CT bunny, lobster; docs/acceleration.md, "Auto"): emission 4
# puts every case where off is over 1.1x faster on the off side, and keeps skipping wherever it saves
# more than 1.2x; MIP's lookups cost more (its runs end where the running maximum says, and lanes
# that jump wait for lanes that sample).
LOOKUP_COST = {"emission": 4.0, "max": 8.0, "minip": 8.0, "isosurface": 8.0}
# Within the ray bounds (emission-absorption) a lookup is dearer than that: the blocks left to jump lie
# behind material, where early termination (which the estimate ignores) ends most rays first. In
# benchmarks/auto_skipping.py block skipping within the bounds was never faster than the bounds alone,
# at break-even costs up to 11.5 (the bunny at 0.5 voxel; docs/measurements/auto-skipping.md): 16
# keeps it for hollow material seen through, finely sampled.
LOOKUP_COST_BOUNDED = 16.0
# The defines of empty-space skipping (a frame without it, and the resolve pass, have none of them).
BLOCK_SKIPPING_DEFINES = ("ACCELERATE", "NUM_LEVELS", "RUNS_IN_CLASSES")  # the in-loop block skipping
SKIPPING_DEFINES = BLOCK_SKIPPING_DEFINES + ("RAY_BOUNDS",)
# "auto" bounds the rays by the non-empty blocks (.ray_bounds) where the estimate says they leave out
# more samples per ray than drawing them costs, in samples per ray: 5-15 ms at 512x512 on llvmpipe,
# about 5 samples a ray; measured, the bounds were 1.12x slower than none on the lobster at 8 voxels
# (2.7 samples a ray left out) and faster everywhere they left out 8 or more (docs/acceleration.md,
# "Ray bounds").
AUTO_BOUNDS_COST = 8.0

COMPOSITING = {"emission_absorption": "COMPOSITE_EMISSION", "isosurface": "COMPOSITE_ISOSURFACE",
               "average": "COMPOSITE_AVERAGE", "mip": "COMPOSITE_MIP", "minip": "COMPOSITE_MINIP",
               "xray": "COMPOSITE_EMISSION"}  # the X-ray: emission's sums unattenuated (XRAY)


def shader_features(scene, count_samples: bool = False, bricked: bool = False, depth: bool = False) -> dict:
    """The defines for exactly the features this scene uses (computed once per frame; the bricked
    passes' program is :func:`bricked_features` of the same); ``depth``: the depth image too (DEPTH: the
    location of its output, after the counts')."""
    r = scene.renderer
    xray = r.compositing == "xray"
    emission = r.compositing == "emission_absorption" or xray
    defines = classification_features(scene)
    defines["TRANSFER_FUNCTION_2D"] = scene.field.kind == "grid" and is_2d(scene.transfer_function)
    defines[COMPOSITING[r.compositing]] = True
    if xray:  # absorption only: no shading, no gradient opacity (dvr_gl.reference.model), nothing terminates
        for key in ("SHADING", "NUM_LIGHTS", "TWO_SIDED", "GRADIENT_TEXTURE", "GRADIENT_OPACITY", "SCATTERING",
                    "NUM_SCATTER_LIGHTS", "PHASE_HG", "SHADOWS", "LIGHT_VOLUME"):
            defines.pop(key, None)
        defines["XRAY"] = True
    if not emission:  # classification, gradient opacity: emission-absorption only
        for key in ("CLASSIFY_PRE", "CLASSIFY_PREINTEGRATED", "ASSOCIATED_COLORS", "GRADIENT_OPACITY"):
            defines.pop(key, None)
        if r.compositing != "isosurface":
            for key in ("SHADING", "NUM_LIGHTS", "TWO_SIDED", "GRADIENT_TEXTURE"):
                defines.pop(key, None)
        elif "SHADING" not in defines:
            defines.pop("GRADIENT_TEXTURE", None)
    if emission and not xray:  # the X-ray's sums take every segment, in any order
        defines["BACK_TO_FRONT"] = r.order == "back_to_front"
        defines["EARLY_TERMINATION"] = r.order == "front_to_back" and r.ert_threshold < 1.0
    defines["JITTER"] = r.jitter
    if r.compositing in ("mip", "minip") and scene.field.kind == "grid":  # several fields: each its own
        defines["REFINE_EXTREMUM"] = r.extremum_refinement or False
        defines["SECOND_BRACKET"] = bool(r.extremum_refinement) and r.extremum_brackets == 2
    # every sample counts in an average; pre-classified blocks of a volume read out of core would need
    # a pass over all its voxels
    out_of_core_pre = scene.field.out_of_core and "CLASSIFY_PRE" in defines
    if acceleration_mode(r.acceleration) != "off" and r.compositing != "average" and not out_of_core_pre:
        defines.update(ACCELERATE=True, NUM_LEVELS=level_count(scene.volume.dims, r.block_size),
                       RUNS_IN_CLASSES=emission)
    defines["COUNT_SAMPLES"] = count_samples
    defines["DEPTH"] = (2 if count_samples else 1) if depth else False
    defines = {k: v for k, v in defines.items() if v is not False}
    return bricked_features(defines) if bricked else defines


def check_depth(scene):
    """Refuse, in one line, a depth image the ray caster does not draw (beyond the registry's check)."""
    if scene.field.kind == "fields":
        raise SceneError("the ray caster draws no depth image of several fields yet: use renderer reference for "
                         "the depth, or leave it out")
    if scene.renderer.order == "back_to_front" and scene.renderer.compositing == "emission_absorption":
        raise SceneError("a depth image needs the opacity accumulated from the eye: set renderer.order = "
                         "front_to_back (the same image)")


def acceleration_mode(value) -> str:
    """``renderer.acceleration`` as "auto", "on" or "off" (True and False, as scene files before
    "auto" wrote it, are "on" and "off")."""
    return {True: "on", False: "off"}.get(value, value) if isinstance(value, bool) else value


def bricked_features(defines: dict) -> dict:
    """The defines of the bricked (or long-ray) passes: the same features, one pass per brick and
    segment window (empty-space skipping and sample counting included)."""
    return {**defines, "BRICKED": True}


class BlockTextures(list):
    """One nearest-filtered float texture per pyramid level, and ``runs``: the runs texture
    (:func:`.acceleration.run_keys` of level 0), or None for emission-absorption, whose level 0
    carries them (:func:`.acceleration.classes_with_runs`); released together."""

    def __init__(self, ctx, levels: list[np.ndarray], mode: str):
        self.level0, self.mode = levels[0], mode  # for the skipping estimate
        if mode == "emission":
            uploaded, runs = [accel.classes_with_runs(levels[0])] + levels[1:], None
        else:
            uploaded, runs = levels, accel.run_keys(levels[0], mode)
        super().__init__(upload_field(ctx, a) for a in uploaded)
        self.runs = upload_field(ctx, runs) if runs is not None else None
        for tex in self + ([self.runs] if self.runs else []):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def release(self):
        for tex in self + ([self.runs] if self.runs else []):
            tex.release()


# llvmpipe stops a shader invocation's loops after 65535 iterations in all (gallivm's
# LP_MAX_TGSI_LOOP_ITERATIONS, one counter per invocation), silently truncating longer rays; rays
# that may take more segments are composited in passes of at most this many, carrying their state
# as bricked passes do.  The margin leaves room for the isosurface's bisection loop.
PASS_SEGMENTS = 65535 - 535
# The counter counts every loop: under ACCELERATE an outer iteration (a lookup) costs one, and its
# inner loop one more than the samples of its run (measured: 30000 outer iterations of one inner
# iteration each stop after 21845), so a segment costs at most 3 and a pass takes a third as many.
ACCELERATED_COST = 3
MAX_INT = 2 ** 31 - 1


def worth_skipping(estimate, sample_distance: float) -> bool:
    """"auto"'s decision from a :class:`.acceleration.SkipEstimate` at this sample distance (world
    units): enough samples saved, and fewer samples plus lookups than samples without skipping."""
    samples = estimate.length / sample_distance  # per ray, without skipping
    lookup = LOOKUP_COST_BOUNDED if estimate.bounded else LOOKUP_COST[estimate.mode]
    cost = (1.0 - estimate.fraction) * samples + lookup * estimate.lookups
    return estimate.fraction >= AUTO_MIN_SKIPPABLE and cost < samples


def segment_windows(scene, accelerated: bool = False) -> list[tuple[int, int]]:
    """Segment index ranges, one per pass: all segments at once unless the longest possible ray
    (the box's diagonal) takes more than :data:`PASS_SEGMENTS` (a third of that where the loop skips
    empty space, ``accelerated``; a segment's shadow rays count theirs too: each as long as the
    diagonal at most, plus one for the loop's exit)."""
    longest = math.ceil(diagonal(scene.volume) / scene.renderer.sample_distance)
    per_pass = PASS_SEGMENTS - scene.renderer.iso_refinement
    cost = ACCELERATED_COST if accelerated else 1
    sc = scene.renderer.scattering
    if sc.enabled and sc.shadows and sc.method == "shadow_rays" and scene.renderer.compositing == "emission_absorption":
        cost += len(sc.lights) * (math.ceil(diagonal(scene.volume) / shadow_step(scene.renderer, scene.volume)) + 1)
    per_pass = max(per_pass // cost, 1)
    if longest <= per_pass:
        return [(0, MAX_INT)]
    return [(k, k + per_pass) for k in range(0, longest + 1, per_pass)]


def whole_volume_brick(volume):
    """The whole volume as the one brick of a bricked pass (core: every voxel)."""
    return plan_bricks(volume.dims, max(volume.dims) + 1, ghost=0)[0]


class RayCastRenderer(GridRenderer):
    name = "raycast"
    description = "GPU ray casting in a GLSL fragment loop"
    shaders = SHADERS

    def __init__(self, ctx=None, count_samples: bool = False, fragment_shader: str = "raycast.frag"):
        """``ctx``: a moderngl context to render with (default: a new headless EGL context).
        ``count_samples``: also record the samples each ray takes (for benchmarks).
        ``fragment_shader``: another program with the same uniforms (benchmarks compare one)."""
        super().__init__(ctx)
        self.count_samples = count_samples
        self.fragment_shader = fragment_shader
        self.counts = None  # count_samples: the last frame's counts per pixel (see count_stats)

    def work(self, scene):
        return limits.ray_samples(scene, "gpu samples")

    # --- acceleration structures ---

    def _block_textures(self, scene, defines, lut, preint=None) -> list:
        """Per-level block textures for this mode (see .acceleration), cached by what they depend on."""
        r, volume = scene.renderer, scene.volume
        support = accel.SUPPORT[r.filter]
        if "CLASSIFY_PRE" in defines:
            voxels = self._classified_voxels(scene)
            pyramids = self._cached("pyramid", (voxels, support, r.block_size), lambda: [
                accel.MinMaxPyramid.build(voxels[..., c], r.block_size, support) for c in range(4)])
        else:
            pyramids = self._cached("pyramid", (volume, support, r.block_size), lambda: (
                accel.MinMaxPyramid.from_ranges(volume.ranges, support) if volume.out_of_core
                else accel.MinMaxPyramid.build(volume.data, r.block_size, support)))
        if "COMPOSITE_EMISSION" not in defines:
            mode = "minip" if "COMPOSITE_MINIP" in defines else "max"
            return self._cached("blocks", ("minmax", pyramids, r.filter, mode), lambda: BlockTextures(
                self.ctx, accel.minmax_textures(pyramids, r.filter), mode))
        # Shaded (or lit) colours differ at every sample, and pre-integrated segments see the table's own
        # values: only empty blocks are jumped then (exactly zero in both).
        constant_allowed = not ("SHADING" in defines or "SCATTERING" in defines or "GRADIENT_OPACITY" in defines
                                or preint is not None)
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
        return self._cached("blocks", key, lambda: BlockTextures(self.ctx, make(), "emission"))

    # --- uniforms ---

    @staticmethod
    def ray_uniforms(scene) -> dict:
        r, cam, vol, img = scene.renderer, scene.camera, scene.field, scene.image  # a FieldSet: the union box
        f, right, up = cam.basis()
        half = cam.half_extent(img.width / img.height)
        lo, hi = vol.box
        ert = r.ert_threshold
        return {"u_eye": cam.eye, "u_forward": f, "u_right": right, "u_up": up, "u_half_extent": half,
                "u_image_size": (img.width, img.height), "u_near": cam.near, "u_box_lo": lo, "u_box_hi": hi,
                "u_sample_distance": r.sample_distance, "u_iso_value": r.iso_value if r.iso_value is not None else 0.0,
                "u_iso_steps": r.iso_refinement, "u_ert_depth": -math.log1p(-ert) if ert < 1.0 else 3.0e38,
                "u_jitter_seed": r.jitter_seed % 2 ** 32, "u_block_size": r.block_size}

    # --- rendering ---

    def brick_reach(self, scene) -> float:
        """A brick owns the segments whose sample lies in its core: pre-integration also reads the
        segment's ends (half a segment away); the isosurface its bracket back to the previous sample."""
        r = scene.renderer
        segment = r.sample_distance / min(scene.volume.spacing)   # voxels, along any axis at most
        if r.compositing == "isosurface" or (r.compositing in ("mip", "minip") and r.extremum_refinement):
            return segment  # the bracket back to the previous sample; the refinement's, one segment each side
        if r.compositing == "emission_absorption" and r.classification == "preintegrated":
            return segment / 2.0
        return 0.0

    # --- sort-last: partial states of bricks, composited elsewhere (dvr_gl.distributed) ---

    def brick_plan(self, scene, edge: int | None = None) -> list:
        """The bricks (:class:`..grid.bricking.Brick`) this scene's volume is rendered in: the
        budget's bricks, or, with ``edge``, bricks of at most ``edge`` voxels a side, ghosts included
        (the ghosts this scene's filter, gradients and segments need)."""
        local, _ = volume_frame_scene(scene)
        defines = shader_features(local)
        if edge is None:
            views = self.grid_views(local, defines)
            return [v.brick for v in views] if views[0].brick is not None else [whole_volume_brick(local.volume)]
        central = ("SHADING" in defines or "GRADIENT_OPACITY" in defines) and "GRADIENT_TEXTURE" not in defines
        return plan_bricks(local.volume.dims, edge, ghost_width(local.renderer.filter, central,
                                                                self.brick_reach(local)))

    def render_state(self, scene, bricks: list) -> np.ndarray:
        """Sort-last rendering's partial image: the compositing state (``height, width, 4`` float32,
        before the resolve; see shaders/raycast.frag's BRICKED) that ``bricks`` (of :meth:`brick_plan`)
        leave, composited among themselves in visibility order from the empty state, as a pass of
        :meth:`render` would carry it.  Early termination sees only these bricks' samples."""
        self._partial = list(bricks)
        try:
            return self.in_volume_frame(scene, lambda local: self._draw_volume(local, {}))
        finally:
            self._partial = None

    def resolve_state(self, scene, state: np.ndarray) -> np.ndarray:
        """The image of a compositing state (:meth:`render_state`'s, or several composited): the
        resolve pass :meth:`render` ends with."""
        self.activate()
        local, mirrored = volume_frame_scene(scene)
        if mirrored:
            state = state[:, ::-1]
        defines = bricked_features(shader_features(local))
        tables = self.table_textures(local, defines, local.renderer.sample_distance)
        height, width = state.shape[:2]
        texture = self.ctx.texture((width, height), 4, np.ascontiguousarray(state[::-1], np.float32).tobytes(),
                                   dtype="f4")
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        try:
            image = self._resolve(local, defines, tables, texture, now(), 0.0, [], [], {})
        finally:
            texture.release()
        return np.ascontiguousarray(image[:, ::-1]) if mirrored else image

    def draw(self, scene) -> np.ndarray:
        """The frame; with ``[[renderer.geometry]]`` the meshes are drawn first (:mod:`..surfaces`),
        the rays end at them, and the volume is composited over them."""
        return with_surfaces(self, scene, self._draw_volume)

    def _draw_volume(self, scene, surfaces: dict) -> np.ndarray:
        self.activate()
        if self.want_depth:
            check_depth(scene)
        if scene.field.kind == "fields":  # several fields: one pass of their mixture (.fields)
            return draw_fields(self, scene, surfaces, shader_features)
        start = now()
        if scene.volume.out_of_core:  # its blocks are the ranges' (dvr_gl.out_of_core): no pass over the voxels
            scene = dataclasses.replace(scene, renderer=dataclasses.replace(
                scene.renderer, block_size=scene.volume.ranges.block_size))
        depth = self.want_depth and getattr(self, "_partial", None) is None  # not in sort-last's partial states
        defines = shader_features(scene, self.count_samples, depth=depth)
        views = self.grid_views(scene, defines)
        tables = {**self.table_textures(scene, defines, scene.renderer.sample_distance), **surfaces}
        tables, light_seconds = self.scattering_tables(scene, defines, views, tables)
        defines, blocks, estimate = self.decide_skipping(scene, defines, tables)
        windows = segment_windows(scene, "ACCELERATE" in defines)
        decided = {"light_volume_seconds": light_seconds,
                   "skippable_estimate": estimate and estimate.fraction, "accelerated": "ACCELERATE" in defines,
                   "lookups_estimate": estimate and estimate.lookups, "ray_bounds": "RAY_BOUNDS" in defines,
                   "outside_bounds_estimate": estimate and estimate.outside, "bounds_seconds": self.bounds_seconds}
        partial = getattr(self, "_partial", None)
        if partial is not None:  # render_state: these bricks' state, not resolved
            views = [GridView(b.tex_lo, b.tex_dims, b) for b in partial]
        bricked = partial is not None or views[0].brick is not None
        if bricked:  # empty bricks left out (all of them, maybe), levels chosen
            views, frame = out_of_core.frame_views(self, scene, defines, views)
            decided.update(frame)
        if (bricked or len(windows) > 1) and "DEPTH" in defines:
            raise SceneError(f"the ray caster draws a depth image in one pass, and this frame takes "
                             f"{'bricks' if bricked else 'passes over windows of its long rays'}: use renderer "
                             f"reference for the depth, raise renderer.sample_distance or "
                             f"renderer.texture_budget_mb, or leave out the depth")
        if bricked or len(windows) > 1:
            if not bricked:  # long rays: the whole volume as one brick, in passes over segment windows
                views = [GridView((0, 0, 0), scene.volume.dims, whole_volume_brick(scene.volume))]
            return self._render_bricks(scene, bricked_features(defines), views, start, windows,
                                       {**tables, **blocks}, decided, resolve=partial is None)
        textures = {**self.view_textures(scene, defines, views[0], resident=True), **tables, **blocks}
        lut = textures["u_lut"].lut
        program = create_program(self.ctx, "fullscreen.vert", self.fragment_shader, defines, roots=SHADERS)
        uniforms = {**self.ray_uniforms(scene), **self.grid_uniforms(scene, views[0]),
                    **self.optics_uniforms(scene, lut)}
        self.bind(program, uniforms, textures)
        width, height = scene.image.width, scene.image.height
        components = (4,) + ((4,) if self.count_samples else ()) + ((1,) if "DEPTH" in defines else ())
        _, fbo = self.target("main", width, height, components)
        rect = box_rectangle(scene, defines=defines)
        gpu_seconds = self.bounds_seconds + self._draw(program, fbo, width, height, self.bands(scene), rect)
        image = self.read(fbo, width, height)
        if "DEPTH" in defines:  # 3e38: no depth (float32 has no infinity to write from GLSL 3.30)
            z = self.read(fbo, width, height, 1, attachment=defines["DEPTH"])[..., 0]
            self.depth = np.where(z >= 1e38, np.inf, z).astype(np.float32)
        self.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines, "bricks": 1,
                      **decided}
        if self.count_samples:
            self.count_stats(self.read(fbo, width, height, 4, attachment=1), scene)
        return image

    def decide_skipping(self, scene, defines, tables) -> tuple[dict, dict, accel.SkipEstimate | None]:
        """This frame's empty-space skipping, decided once for all its passes: the defines (without
        ACCELERATE where it is off, or "auto" finds too little to skip; with RAY_BOUNDS where the rays
        are bounded by the non-empty blocks), the textures to bind (the block textures, the whole
        volume's, bricked or not; the ray bounds) and the estimate ("auto" only)."""
        self.bounds_seconds = 0.0  # drawing the ray bounds, part of the frame's GPU time
        if "ACCELERATE" not in defines:
            return defines, {}, None
        preint = tables["u_preint"].table if "u_preint" in tables else None
        blocks = self._block_textures(scene, defines, tables["u_lut"].lut, preint)
        faces = self._bounds_faces(scene, blocks) if "COMPOSITE_EMISSION" in defines else None
        planes = faces.clip_depths(scene.camera) if faces is not None else None
        auto = acceleration_mode(scene.renderer.acceleration) == "auto"
        estimate, textures = None, {}
        if planes is not None:
            if auto:  # the samples per ray the bounds would leave out
                estimate = self.skip_estimate(scene, blocks, True)
                left_out = estimate.outside * estimate.ray_length / scene.renderer.sample_distance
            if not auto or left_out >= AUTO_BOUNDS_COST:
                textures["u_ray_bounds"] = self.draw_ray_bounds(scene, faces, planes, defines)
                defines = {**defines, "RAY_BOUNDS": True}
        if auto and "RAY_BOUNDS" not in defines:  # the in-loop estimate over whole rays
            estimate = self.skip_estimate(scene, blocks, False)
        if auto and not worth_skipping(estimate, scene.renderer.sample_distance):
            return {k: v for k, v in defines.items() if k not in BLOCK_SKIPPING_DEFINES}, textures, estimate
        textures.update({f"u_blocks{level}": tex for level, tex in enumerate(blocks)})
        if blocks.runs is not None:
            textures["u_runs"] = blocks.runs
        return defines, textures, estimate

    def _bounds_faces(self, scene, blocks) -> "BoundsFaces | None":
        """The faces of the non-empty blocks (cached with the blocks); None where no block is empty
        (the bounds would be the box's)."""
        vol, r = scene.volume, scene.renderer
        occ = ray_bounds.occupied(blocks.level0)
        if occ.all() or min(vol.dims) < 2:  # a flat box's faces are seen edge on
            return None
        return self._cached("ray bounds faces", (blocks,), lambda: BoundsFaces(
            self.ctx, occ, ray_bounds.boundary_faces(occ, r.block_size, vol.dims, vol.spacing, vol.origin),
            r.block_size, vol))

    def draw_ray_bounds(self, scene, faces: "BoundsFaces", planes, defines) -> moderngl.Texture:
        """This frame's ray bounds: the faces drawn into a two-channel float target, MIN-blended,
        between the depths ``planes`` (:func:`.ray_bounds.clip_depths`)."""
        width, height = scene.image.width, scene.image.height
        (bounds,), fbo = self.target("ray bounds", width, height, (2,))
        fbo.use()
        self.ctx.viewport = (0, 0, width, height)
        fbo.clear(3.0e38, 3.0e38, 0.0, 0.0)
        start = now()
        if faces.count:
            program = create_program(self.ctx, "ray_bounds.vert", "ray_bounds.frag",
                                     {"CAMERA_ORTHOGRAPHIC": "CAMERA_ORTHOGRAPHIC" in defines}, roots=SHADERS)
            self.bind(program, self.ray_uniforms(scene), {})
            aspect = width / height
            program["u_view_projection"].write(gl_matrix(projection_matrix(scene.camera, aspect, *planes)
                                                         @ view_matrix(scene.camera)))
            self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.CULL_FACE)
            self.ctx.enable(self.ctx.BLEND)
            self.ctx.blend_equation = moderngl.MIN
            try:
                faces.vertex_array(program).render(moderngl.TRIANGLES)
            finally:
                self.ctx.blend_equation = moderngl.FUNC_ADD
                self.ctx.disable(self.ctx.BLEND)
        self.ctx.finish()
        self.bounds_seconds = now() - start
        return bounds

    def count_stats(self, counts: np.ndarray, scene):
        """COUNT_SAMPLES: the frame's counts (height, width, 4: samples, jumps, lookups, segments
        jumped per pixel) into the stats, per ray through the volume's box (ray bounds may leave such
        a ray without a sample); kept in :attr:`counts`."""
        self.counts = counts
        c = counts.reshape(-1, 4).astype(np.float64)
        samples, jumps, lookups, jumped = c.T
        origins, directions = scene.camera.pixel_rays(scene.image.width, scene.image.height)
        t0, t1 = rays_mod.intersect_box(origins, directions, *scene.volume.box)
        hit = (t1 > np.maximum(t0, scene.camera.near_distance(directions))) | ((samples + jumps) > 0)
        self.stats["samples"] = int(samples.sum())
        self.stats["segments"] = int((samples + jumped).sum())  # sampled or jumped
        self.stats["samples_per_ray"] = float(samples[hit].mean()) if hit.any() else 0.0
        self.stats["jumps_per_ray"] = float(jumps[hit].mean()) if hit.any() else 0.0
        self.stats["lookups_per_ray"] = float(lookups[hit].mean()) if hit.any() else 0.0

    def skip_estimate(self, scene, blocks, bounded: bool = False) -> accel.SkipEstimate:
        """:func:`.acceleration.skip_estimate` of this frame (cached per view and blocks); ``bounded``:
        over the ray bounds only."""
        r, img = scene.renderer, scene.image
        mode = "isosurface" if r.compositing == "isosurface" else blocks.mode
        key = (blocks, scene.camera, img.width, img.height, r.iso_value)
        # host data only, not in the texture cache: one entry bounded, one not (a frame may ask for both)
        cache = self.__dict__.setdefault("_estimates", {})
        last = cache.get(bounded)
        if last is None or not same_key(last[0], key):
            cache[bounded] = (key, accel.skip_estimate(blocks.level0, mode, r.block_size, scene.volume,
                                                       scene.camera, img.width / img.height,
                                                       iso_value=r.iso_value, bounded=bounded))
        self._skippable = cache[bounded]  # the estimate the frame's decision used last
        return self._skippable[1]

    def bands(self, scene) -> int:
        """Horizontal bands to draw a one-pass frame in: one for a frame estimated under
        :data:`BAND_SECONDS`, else about that much estimated work a band (at most a row each)."""
        seconds = limits.estimated_seconds(self.work(scene))
        return int(min(scene.image.height, max(1, math.ceil(seconds / BAND_SECONDS))))

    def _draw(self, program, fbo, width, height, bands: int = 1, rect=None, clear: bool = True) -> float:
        """Draw the full-screen pass into ``fbo``, in ``bands`` scissored bands of rows; between bands
        the frame reports progress, so that Ctrl-C and a sandbox's time limit stop it there (no Python
        runs while one draw call is under way).  ``rect`` (x, y, w, h; :func:`box_rectangle`): only the
        pixels whose rays can meet the volume are drawn, the rest cleared to zero, what the pass writes for
        a ray that misses it (``clear`` False: left as they are, a brick's pass over a copy of the state).
        Returns the seconds spent drawing."""
        fbo.use()
        self.ctx.viewport = (0, 0, width, height)
        self.ctx.disable(self.ctx.BLEND | self.ctx.DEPTH_TEST)
        vao = self.ctx.vertex_array(program, [])
        edges = np.linspace(0, height, bands + 1).round().astype(int)
        x, w = (0, width) if rect is None else (rect[0], rect[2])
        if rect is not None:
            edges = np.clip(edges, rect[1], rect[1] + rect[3])
        if rect is not None and clear:
            fbo.scissor = None
            fbo.clear(0.0, 0.0, 0.0, 0.0)
        try:
            drawn = now()
            for band, (y0, y1) in enumerate(zip(edges[:-1], edges[1:])):
                fbo.scissor = (x, int(y0), w, int(y1 - y0)) if bands > 1 or rect is not None else None
                if y1 > y0 and w > 0:
                    vao.render(mode=self.ctx.TRIANGLES, vertices=3)
                self.ctx.finish()
                if bands > 1:
                    self.report(band + 1, bands)
            return now() - drawn
        finally:
            fbo.scissor = None
            vao.release()

    def _render_bricks(self, scene, defines, views, start, windows, tables, decided, resolve=True) -> np.ndarray:
        """One pass per brick and segment window; ``tables``: the frame's tables and block textures
        (the whole volume's, shared by every pass); ``decided``: the stats of the skipping decision;
        ``resolve``: False returns the compositing state the passes left (:meth:`render_state`)."""
        r = scene.renderer
        program = create_program(self.ctx, "fullscreen.vert", "raycast.frag", defines, roots=SHADERS)
        lut = tables["u_lut"].lut
        counting = "COUNT_SAMPLES" in defines
        width, height = scene.image.width, scene.image.height
        front_to_back = "BACK_TO_FRONT" not in defines
        bricks = visibility_order([v.brick for v in views], scene.volume, scene.camera, front_to_back)
        by_brick = {v.brick: v for v in views}
        per_voxel = texel_bytes(scene.volume.dtype) + self.texture_bytes_per_voxel(defines)
        resident = sum(np.prod(v.dims) for v in views) * per_voxel <= r.texture_budget_mb * 2 ** 20
        initial = {"COMPOSITE_MIP": -3.0e38, "COMPOSITE_MINIP": 3.0e38}
        first = next((v for k, v in initial.items() if k in defines), 0.0)
        targets = [self.target(f"state {i}", width, height, (4, 4) if counting else (4,)) for i in range(2)]
        targets[0][1].use()
        self.ctx.clear(first, first, first, 0.0)  # projection.glsl's EMPTY_STATE (z: the refined extremum)
        if counting:  # the counts start at zero, whatever the state's initial value
            targets[0][0][1].write(np.zeros((height, width, 4), np.float32))
        common = {**self.ray_uniforms(scene), **self.optics_uniforms(scene, lut)}
        gpu_seconds, current = self.bounds_seconds, 0
        to_global = -np.asarray(scene.volume.origin) / np.asarray(scene.volume.spacing)
        passes = [(b, w) for b in bricks for w in (windows if front_to_back else windows[::-1])]
        for done, (brick, window) in enumerate(passes):
            view = by_brick[brick]
            textures = {**self.view_textures(scene, defines, view, resident), **tables,
                        "u_state": targets[current][0][0]}
            if counting:
                textures["u_counts"] = targets[current][0][1]
            lo, hi = brick.world_box(scene.volume)
            single = np.asarray(scene.volume.dims) == 1
            uniforms = {**common, **self.grid_uniforms(scene, view), "u_world_to_global_offset": to_global,
                        "u_world_to_global_scale": 1.0 / np.asarray(scene.volume.spacing),
                        "u_core_lo": np.where(single, -1e30, brick.core_lo),
                        "u_core_hi": np.where(single, 1e30, brick.core_hi),
                        "u_core_closed": np.asarray(brick.last, dtype=float), "u_brick_lo": lo, "u_brick_hi": hi,
                        "u_segment_window": window}
            self.bind(program, uniforms, textures)
            # only the pixels whose rays can meet the brick (a ray that misses it keeps its state): the state copied
            # first, then those drawn over it (the counts' second attachment: the whole pass, as before)
            rect = None if counting else box_rectangle(scene, (lo, hi))  # None: the whole image, no copy needed
            if rect is not None:
                self.ctx.copy_framebuffer(targets[1 - current][1], targets[current][1])
            gpu_seconds += self._draw(program, targets[1 - current][1], width, height, rect=rect, clear=False)
            current = 1 - current
            self.report(done + 1, len(passes))  # long bricked or windowed frames: a progress bar, Ctrl-C
        if not resolve:
            self.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines,
                          "bricks": len(bricks), "passes": len(passes), **decided}
            return self.read(targets[current][1], width, height)
        return self._resolve(scene, defines, tables, targets[current][0][0], start, gpu_seconds, bricks, passes,
                             decided, targets[current] if counting else None)

    def _resolve(self, scene, defines, tables, state, start, gpu_seconds, bricks, passes, decided, counted=None):
        """The resolve pass (shaders/resolve.frag): the state texture ``state`` to the image."""
        lut = tables["u_lut"].lut
        width, height = scene.image.width, scene.image.height
        resolve = create_program(self.ctx, "fullscreen.vert", "resolve.frag",
                                 {k: v for k, v in defines.items() if k not in SKIPPING_DEFINES}, roots=SHADERS)
        self.bind(resolve, {"u_unit_distance": scene.transfer_function.unit_distance,
                            **self.optics_uniforms(scene, lut)}, {**tables, "u_state": state})
        out = self.target("main", width, height)[1]
        gpu_seconds += self._draw(resolve, out, width, height, rect=box_rectangle(scene))
        image = self.read(out, width, height)
        self.stats = {"seconds": now() - start, "gpu_seconds": gpu_seconds, "defines": defines,
                      "bricks": len(bricks), "passes": len(passes), **decided}
        if counted is not None:
            self.count_stats(self.read(counted[1], width, height, 4, attachment=1), scene)
        return image
