"""The Fourier renderer in GL (see the package doc and ``dvr_gl/renderers/fourier/README.md``).

Once per volume, transfer function (the X-ray's classified voxels) and settings: the spectra, uploaded
as float32 3D textures, two complex channels a texture (:mod:`.spectrum`).  Per view: the central slice
drawn as one full-screen pass over the slice's frequency grid (``shaders/slice.frag``), read
back, and turned into the image on the host (:func:`.projection.finish`: the filter, the phase, the
inverse 2D transform, the compositing mode's classification).
"""

from __future__ import annotations

import math
import time

import moderngl
import numpy as np

from ... import limits
from ...errors import SceneError
from ...gl.shaders import create_program, shader_root
from ...sandbox import check_bytes
from ..base import GLRenderer
from .projection import Frame, Shell, channels, clips_exactly, finish, ghost_layers, weighted
from .spectrum import WINDOWED, Spectrum

#: The slice kernels read two taps at a time (``FourierRenderer.paired_taps``): their weights are positive.
#: The trilinear slice too since its pairs need no mirror branch (one filtered read for its eight fetches:
#: 1.10x a 512x512 X-ray view of the 256^3 blobs at padding 2, interleaved on the very busy machine; with the
#: mirrored pairs before, the average's was no faster, 153 against 155 ms).
PAIRED = ("cubic_bspline", "kaiser_bessel", "trilinear")

#: Channels x M log2 M of the padded volume's transform (the first frame's): 8e7-1.3e8 a second measured on
#: two shared cores (240^3 to 800^3 spectra; 800^3: 113 s); the bound, about an hour there.
FFT_SAMPLES = limits.work_unit("fft samples", bound=1e11, rate=1e8)

#: Its own GLSL (before the common library).
SHADERS = (shader_root(__file__),)


class SpectrumTextures:
    """The spectra as 3D textures ``(Mx / 2 + 1 + 2 XPAD, My, Mz)`` (x from ``-XPAD`` to ``Mx / 2 + XPAD``: the
    half spectrum and a few columns of the other half, :func:`extended_into`): RGBA32F of two complex
    channels each, and an odd last channel alone in an RG32F texture (read as ``(re, im, 0, 1)``: the
    slice's second channel there is never used).  Rolled by ``ROLL`` along y and z (index ``k`` in row
    ``(k + ROLL) mod M``): a linearly filtered read is precise to about its row x 6e-8 texels on llvmpipe,
    so the low frequencies, the spectrum's largest values, of either sign lie in low rows."""

    #: Rows the spectra are rolled by along y and z (the slice shader's ``ROLL``).
    ROLL = 8
    #: Columns of the half not stored on either side (the slice shader's ``XPAD``): six taps from a fragment's
    #: x in [0, M/2] reach x - 2 .. x + 3, so each pair of taps is one filtered read, with no mirrored pair.
    XPAD = 3

    def __init__(self, ctx, data: np.ndarray, interpolation: str, padding: float, border: int, taps: int):
        """The spectrum of the channels ``data`` (:class:`.spectrum.Spectrum`, complex64), each channel's half
        written into its texture's layout as it is transformed (no copy of the spectra kept on the host);
        ``upload_seconds``: the time of the layout and the upload, inside ``spectrum.seconds``."""
        self.ctx, self.textures, self.upload_seconds = ctx, [], 0.0
        self.count = data.shape[-1]
        self._texels = None
        self.spectrum = Spectrum(data, interpolation, padding, border, taps, np.float32, sink=self._add)
        self._texels = None

    def _add(self, c: int, half: np.ndarray):
        """Channel ``c``'s half spectrum (a buffer the next channel overwrites) into the texels of its
        texture, two channels a texture (one buffer for every pair), uploaded once the texture is full."""
        start = time.perf_counter()
        mz, my, mxh = half.shape
        columns = mxh + 2 * self.XPAD
        width = min(2, self.count - (c - c % 2))  # two channels a texture, an odd last one alone
        if self._texels is None or self._texels.shape[3] != width:
            self._texels = np.empty((mz, my, columns, width), np.complex64)  # re, im(, re, im)
        extended_into(self._texels[..., c % 2], half, self.XPAD, self.ROLL)
        if c % 2 == width - 1:
            tex = self.ctx.texture3d((columns, my, mz), 2 * width, self._texels.view(np.float32), dtype="f4")
            # LINEAR for the paired taps' filtered reads (texelFetch ignores it); y and z periodic, x clamped
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = False
            self.textures.append(tex)
        self.upload_seconds += time.perf_counter() - start

    def release(self):
        for t in self.textures:
            t.release()


def extended_into(out: np.ndarray, half: np.ndarray, pad: int, shift: int):
    """``out`` ``(Mz, My, Mx / 2 + 1 + 2 pad)``: the spectrum at x ``-pad .. Mx / 2 + pad`` from its half
    ``half`` (periodic, ``S(-k)`` the conjugate of ``S(k)``: a column of the half not stored is the
    conjugate of its mirror, y and z negated), rolled by ``shift`` along y and z (:func:`rolled_into`)."""
    mxh = half.shape[2]
    m = 2 * (mxh - 1)
    rolled_into(out[:, :, pad:pad + mxh], half, shift)
    for column in [*range(pad), *range(pad + mxh, out.shape[2])]:
        x = (column - pad) % m
        if x < mxh:
            rolled_into(out[:, :, column], half[:, :, x], shift)
        else:  # negated rows: row k holds (-k) mod M, the flipped rows shifted by one
            mirror = np.roll(half[::-1, ::-1, m - x], 1, axis=(0, 1))
            rolled_into(out[:, :, column], np.conj(mirror), shift)


def rolled_into(out: np.ndarray, half: np.ndarray, shift: int):
    """``out[(z + shift) mod Mz, (y + shift) mod My, x] = half[z, y, x]`` (``np.roll`` along the first two
    axes, written into ``out`` without a temporary)."""
    for axis_blocks in _roll_blocks(half.shape[0], shift):
        for row_blocks in _roll_blocks(half.shape[1], shift):
            out[axis_blocks[0], row_blocks[0]] = half[axis_blocks[1], row_blocks[1]]


def _roll_blocks(m: int, shift: int):
    """The (destination, source) slices of a roll by ``shift`` along an axis of ``m``."""
    s = shift % m
    return ((slice(s, None), slice(None, m - s)), (slice(None, s), slice(m - s, None)))


class ShellTexture:
    """The ghosted channels (at most four) for the shell pass, float32 of one component a channel (R32F for
    the average; a fourth component of 0 where there are three, never read back), sampled texel by texel.
    The trilinear field (``faces``): the six faces' sample layers, a 2D array texture (beyond a face the
    field is the face layer's bilinear interpolant times a ramp: the faces' memory, and 4 taps a piece for
    8 from the whole volume's; the pass 1.4x faster at 256^3, 512x512); otherwise the channels zero-padded
    (:class:`.projection.Shell`), a 3D texture."""

    #: The face walk for the trilinear field (False: the whole volume's texture, as the other fields).
    face_walk = True

    def __init__(self, ctx, scene, ghosted: np.ndarray, border: int):
        self.shell = Shell(scene, border)
        self.empty = self.shell.empty(ghosted)  # nothing beyond the box: no pass, and a one-texel texture
        self.faces = self.walks_faces(scene, border)
        if self.empty:
            ghosted = np.zeros((1, 1, 1, ghosted.shape[-1]))
            self.faces = False
        components = self.components = {1: 1, 2: 2}.get(ghosted.shape[-1], 4)
        if self.faces:
            self.textures = {"u_faces": self._face_layers(ctx, ghosted, components)}
            return
        padded = self.shell.padded(ghosted) if not self.empty else ghosted
        self.dims = padded.shape[2::-1][:3]  # (x, y, z)
        texture = ctx.texture3d(self.dims, components, _texels(padded, components), dtype="f4")
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.textures = {"u_field": texture}

    @classmethod
    def walks_faces(cls, scene, border: int) -> bool:
        """Whether the pass walks the faces: the trilinear field with no ghost layers."""
        return cls.face_walk and scene.renderer.filter == "linear" and border == 0

    @classmethod
    def bytes(cls, scene, border: int) -> int:
        """At most what the texture takes (four float32 components a texel)."""
        dims = [n + 2 * border for n in scene.volume.dims]  # x, y, z
        if cls.walks_faces(scene, border):
            faces = [(dims[2], dims[1]), (dims[2], dims[0]), (dims[1], dims[0])]  # (rows, columns)
            return 16 * 6 * (max(f[0] for f in faces) + 2) * (max(f[1] for f in faces) + 2)
        return 16 * int(np.prod([n + 2 * Shell(scene, border).pad for n in dims]))

    @staticmethod
    def _face_layers(ctx, ghosted: np.ndarray, components: int):
        """A 2D array texture of the six faces' sample layers of ``ghosted`` ``(nz, ny, nx, C)``, each zero-padded
        by one texel and to the largest face's size: layer ``2 a + side`` is axis ``a``'s (x, y, z) low
        (``side`` 0) or high face, its columns and rows the other two axes in the order x, y, z."""
        # (rows, columns, C), by views: np.take copies a non-contiguous array whole first (the X-ray's
        # channel-major channels: 1.5 s at 256^3)
        faces = [ghosted[(slice(None),) * (2 - a) + (i,)] for a in range(3) for i in (0, -1)]
        rows, columns = (max(f.shape[k] for f in faces) + 2 for k in (0, 1))
        layers = np.zeros((6, rows, columns, components), np.float32)
        for layer, face in zip(layers, faces):
            layer[1:face.shape[0] + 1, 1:face.shape[1] + 1, :face.shape[2]] = face
        texture = ctx.texture_array((columns, rows, 6), components, layers, dtype="f4")
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return texture

    def release(self):
        for texture in self.textures.values():
            texture.release()


def _texels(values: np.ndarray, components: int) -> np.ndarray:
    """``values`` (..., C) as float32 texels of ``components`` (C, padded with zeros)."""
    texels = np.zeros(values.shape[:-1] + (components,), np.float32)
    texels[..., :values.shape[-1]] = values
    return texels


class KernelTable:
    """The windowed slice kernel (:func:`.spectrum.kernel`) and its derivative at ``SIZE`` evenly spaced
    ``|x|`` from 0 to its half-width, an RG32F texture ``(SIZE, 1)`` the slice shader interpolates linearly:
    within ``h^2 max|k''| / 8`` of the kernel, about 1e-8 (a few the kernel's own evaluation in float32
    took 30 terms of two Bessel series a weight, 12 weights a slice sample)."""

    SIZE = 8192

    def __init__(self, ctx, interpolation: str, padding: float, taps: int):
        from .spectrum import kernel

        x = np.linspace(0.0, taps / 2.0, self.SIZE)
        k = kernel(interpolation, padding, taps)
        values = np.stack([k(x), k(x, derivative=True)], axis=-1)
        values[-1] = 0.0  # the half-width: zero, and beyond it
        self.texture = ctx.texture((self.SIZE, 1), 2, values.astype(np.float32), dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def release(self):
        self.texture.release()


class FourierRenderer(GLRenderer):
    name = "fourier"
    #: The slice's taps two by two, one linearly filtered read a pair, where that is faster and the weights
    #: are positive (:data:`PAIRED`; not with the depth cue, whose derivative weights change sign): 27
    #: reads a slice sample for 216 at six taps, 8 for 64.
    paired_taps = True
    #: Fragments of the filter probe (:meth:`filters_in_float`), and the largest error of a float filter.
    PROBES, FLOAT_FILTER = 256, 1e-5

    def filters_in_float(self) -> bool:
        """Whether this GL's linear filter weighs texels with float precision (llvmpipe: within 1e-7),
        which the paired taps need; GPUs' filters often weigh with 8 bits (errors up to 1 / 512), and
        there the slice is read tap by tap.  Probed once a renderer: ``PROBES`` reads between two texels."""
        if getattr(self, "_float_filter", None) is None:
            data = np.tile(np.array([0.0, 1.0], np.float32), 4)  # (2, 2, 2): each texel's x index
            texture = self.ctx.texture3d((2, 2, 2), 1, data, dtype="f4")
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            program = create_program(self.ctx, "fullscreen.vert", "filter_probe.frag", {}, roots=SHADERS)
            _, fbo = self.target("filter probe", self.PROBES, 1)
            fbo.use()
            texture.use(location=0)
            program["u_texels"].value = 0
            quad = self.ctx.vertex_array(program, [])
            quad.render(moderngl.TRIANGLES, vertices=3)
            errors = self.read(fbo, self.PROBES, 1, flip=False)[..., 0]
            quad.release()
            texture.release()
            self._float_filter = bool(np.abs(errors).max() <= self.FLOAT_FILTER)
        return self._float_filter

    def check_textures(self, scene, gl):
        """The spectrum's textures and the slice's target against the GL limits (before any transform)."""
        from .spectrum import padded_length

        r = scene.renderer
        border = ghost_layers(scene)
        dims = [padded_length(n + 2 * border, r.padding) for n in scene.volume.dims]  # with the ghost layers
        side = max(dims[0] // 2 + 1 + 2 * SpectrumTextures.XPAD, dims[1], dims[2])
        if side > gl.texture_3d_size:
            raise SceneError(f"fourier's spectrum needs a {side}-texel 3D texture, over this GL's "
                             f"{gl.texture_3d_size}: use a smaller renderer.padding or volume"
                             f"{' or renderer.kernel_width' if r.filter == 'gaussian' else ''}")
        limits.check_texture("fourier's slice", Frame(scene).size, gl,
                             "frame the volume in the image (camera.view_height), or use a smaller image or "
                             "renderer.slice_bandwidth")
        count = (4 if r.compositing == "xray" else 1) + (3 if r.compositing == "xray" else 1) * r.hemispherical_shading
        # the float64 spectra on the host and their float32 textures, and the shell pass's float32 channels
        shell = ShellTexture.bytes(scene, border) if clips_exactly(scene) else 0
        columns = dims[0] // 2 + 1 + 2 * SpectrumTextures.XPAD
        check_bytes(count * 24 * columns * dims[1] * dims[2] + shell, "fourier's spectra",
                    f"use a smaller renderer.padding or volume{' or renderer.kernel_width' * (r.filter == 'gaussian')}")

    def work(self, scene) -> limits.Work:
        """The first frame's transform: channels x ``M log2 M`` of the padded volume (``M`` samples; the
        ghost layers included), an upper bound on what the later frames, which reuse it, take."""
        from .spectrum import padded_length

        r = scene.renderer
        border = ghost_layers(scene)
        # a fast length is looked for only where a transform could be made (the search is long for huge n)
        dims = [padded_length(n + 2 * border, r.padding) if n + 2 * border < 1 << 20 else
                math.ceil(r.padding * (n + 2 * border)) for n in scene.volume.dims]
        samples = float(np.prod([float(m) for m in dims]))
        count = (4 if r.compositing == "xray" else 1) * (2 if r.hemispherical_shading else 1)
        fix = "use a smaller renderer.padding or volume" + (" or renderer.kernel_width" if r.filter == "gaussian"
                                                            else "")
        return limits.Work(count * samples * math.log2(max(samples, 2.0)), FFT_SAMPLES,
                           f"{count} channel{'s' * (count > 1)} x a {dims[0]}x{dims[1]}x{dims[2]} padded spectrum "
                           f"({border} ghost layers a face)", fix)

    def draw(self, scene) -> np.ndarray:
        self.activate()
        r = scene.renderer
        xray = r.compositing == "xray"
        key = (scene.volume, r.compositing, scene.transfer_function if xray else None)
        key = (*key, r.filter, r.kernel_width, r.hemispherical_shading)
        self.report(0, 3)  # the steps: the ghosted channels, their transform, the view (the first two cached)
        made = {"channels": 0.0, "transform": 0.0, "upload": 0.0}  # seconds of what was made afresh

        def timed(what, make):
            start = time.perf_counter()
            value = make()
            made[what] = time.perf_counter() - start
            return value

        data, offsets, border = self._cached("channels", key,
                                             lambda: timed("channels", lambda: channels(scene, np.float32)))
        self.report(1, 3)
        taps = r.slice_taps if r.slice_interpolation in WINDOWED else 4
        textures = self._cached("spectrum textures", (data, r.slice_interpolation, r.padding, taps),
                                lambda: timed("transform", lambda: SpectrumTextures(self.ctx, data,
                                                                                    r.slice_interpolation,
                                                                                    r.padding, border, taps)))
        spectrum = textures.spectrum
        if made["transform"]:  # the textures' layout and upload, timed apart
            made["upload"] = textures.upload_seconds
            made["transform"] -= textures.upload_seconds
        self.report(2, 3)
        start = time.perf_counter()
        # the slice's grid, the chords and the short chords' rays: made again only for a new view, image or volume
        # (camera and volume are frozen: by identity; the image's settings are not: its size by value); what
        # does not depend on the cutoff (chords, short chords, phases) is shared by the frames of every cutoff
        # (a bench or a user alternating cutoffs remade them each view: 5.1 ms at 512x512 on the blobs)
        view = (scene.camera, scene.image.width, scene.image.height, scene.volume, r.slice_bandwidth)
        shared = self._cached("frame's view", view, dict)
        frame = self._cached("frame", (*view, r.slice_cutoff), lambda: Frame(scene, shared))
        wf, hf = frame.size
        cued = r.depth_cue < 1.0
        count = len(textures.textures)
        windowed = r.slice_interpolation in WINDOWED
        gaussian = r.filter == "gaussian"
        defines = {"TRILINEAR": r.slice_interpolation == "trilinear", "TEXTURES": str(count), "SLICE_TAPS": str(taps),
                   "TABLE": str(KernelTable.SIZE) if windowed else "", "DEPTH_CUE": cued,
                   "PAIRED_TAPS": (self.paired_taps and r.slice_interpolation in PAIRED and not cued
                                   and self.filters_in_float()),
                   "ROLL": str(SpectrumTextures.ROLL), "XPAD": str(SpectrumTextures.XPAD),
                   "FILTER_GAUSSIAN": gaussian, "FILTER_POWER": "" if gaussian else
                   str({"linear": 2, "cubic_bspline": 4}[r.filter])}
        program = create_program(self.ctx, "fullscreen.vert", "slice.frag",
                                 {k: v for k, v in defines.items() if v}, roots=SHADERS)
        attachments = (4,) * (count * (2 if cued else 1))
        columns = frame.columns  # the half slice: the projection's transform is Hermitian
        _, fbo = self.target("slice", columns, hf, attachments)
        fbo.use()
        for unit, tex in enumerate(textures.textures):
            tex.use(location=unit)
        program["u_spectra"].value = list(range(count)) if count > 1 else 0  # a one-element array reads as one
        if windowed:  # the unit after the spectra's
            table = self._cached("kernel table", (r.slice_interpolation, r.padding, taps),
                                 lambda: KernelTable(self.ctx, r.slice_interpolation, r.padding, taps))
            table.texture.use(location=count)
            program["u_kernel"].value = count
        spacing = np.asarray(scene.volume.spacing, float)
        self.bind(program, {"u_dims": spectrum.dims, "u_size": frame.size,
                            "u_frequency_step": (1.0 / (wf * frame.pixel), 1.0 / (hf * frame.pixel)),
                            "u_right": tuple(frame.right), "u_down": tuple(frame.down),
                            "u_grid_scale": tuple(np.asarray(spectrum.dims) * frame.spacing),
                            "u_spacing": tuple(spacing), "u_filter_scale": float(np.prod(spacing)),
                            **({"u_kernel_width": r.kernel_width} if gaussian else {}),
                            **({"u_depth_dir": tuple(frame.depth_direction(spectrum)),
                                "u_forward": tuple(frame.forward)} if cued else {})}, {})
        quad = self.ctx.vertex_array(program, [])
        self._draw_kept(fbo, quad, frame)
        quad.release()
        read = []
        kept = frame.kept[0]  # with a cutoff only its first columns are read: the rest is zero (finish pads them)
        for i in range(len(attachments)):
            if kept == columns:
                raw = self.read(fbo, columns, hf, attachment=i, flip=False)  # fragment row j: the slice's row j
            else:
                raw = np.empty((hf, kept, 4), np.float32)
                fbo.read_into(raw, viewport=(0, 0, kept, hf), components=4, dtype="f4", attachment=i)
            pair = raw.view(np.complex64)  # (re, im) twice: two complex64 channels, kept in float32 on the host
            read += [pair[..., 0], pair[..., 1]]
        # the values (two channels a texture, the last pair padded), then their derivatives
        slices = read[:spectrum.count]
        derivatives = {c: read[2 * count + c] for c in weighted(scene)} if cued else None
        shell = self._shell(scene, frame, data, border) if clips_exactly(scene) else None
        drawn = time.perf_counter()
        image = finish(scene, frame, spectrum, slices, offsets, derivatives, shell)
        end = time.perf_counter()
        self.report(3, 3)
        self.stats.update(preprocess_seconds=sum(made.values()), channels_seconds=made["channels"],
                          transform_seconds=made["transform"], upload_seconds=made["upload"],
                          spectrum_bytes=spectrum.bytes,
                          spectrum_dims=spectrum.dims, fft=spectrum.library, slice_size=frame.size,
                          slice_seconds=drawn - start, inverse_seconds=end - drawn, view_seconds=end - start)
        return image.astype(np.float32)

    @staticmethod
    def _draw_kept(fbo, quad, frame):
        """The slice pass over what ``renderer.slice_cutoff`` keeps (:attr:`.projection.Frame.kept`): the
        first columns of the first and the last rows (the negative frequencies), each band scissored, the rows
        between them in those columns cleared to zero (only those columns are read back: clearing the whole
        target took 0.75 ms of llvmpipe's time a view, the draw 0.95); the whole half slice without a cutoff."""
        columns, low, high = frame.kept
        if (columns, low, high) == (frame.columns, frame.size[1], 0):
            quad.render(moderngl.TRIANGLES, vertices=3)
            return
        between = frame.size[1] - low - high
        if between > 0 and columns:
            fbo.clear(0.0, 0.0, 0.0, 0.0, viewport=(0, low, columns, between))
        for first, rows in ((0, low), (frame.size[1] - high, high)):  # fragment row j: the slice's row j
            if rows and columns:
                fbo.scissor = (0, first, columns, rows)
                quad.render(moderngl.TRIANGLES, vertices=3)
        fbo.scissor = None

    def _shell(self, scene, frame, data, border) -> np.ndarray:
        """The shell pass (``shaders/shell.frag``): ``(H, W, C)`` whole-line integrals beyond the box
        (None when the ghosted field is zero there)."""
        from .projection import cue_line

        r, img = scene.renderer, scene.image
        texture = self._cached("shell texture", (data, r.depth_cue < 1.0),  # the cue sets the nodes
                               lambda: ShellTexture(self.ctx, scene, data, border))
        if texture.empty:
            return None
        shell = texture.shell
        defines = {"NODES": str(shell.nodes), "CUBIC_BSPLINE": r.filter == "cubic_bspline", "FACES": texture.faces,
                   "CUED": r.depth_cue < 1.0, "GATHER": texture.faces and texture.components == 1}
        program = create_program(self.ctx, "fullscreen.vert", "shell.frag",
                                 {k: v for k, v in defines.items() if v}, roots=SHADERS)
        _, fbo = self.target("shell", img.width, img.height)
        fbo.use()
        nodes, weights = np.polynomial.legendre.leggauss(shell.nodes)
        lo, hi = (np.asarray(v, float) for v in scene.volume.bounds)
        spacing = np.asarray(scene.volume.spacing, float)
        cued = np.zeros(4)
        cued[list(weighted(scene))] = 1.0
        # the longest stretch through the shell crosses at most its extent's voxel planes per axis, and one more
        extent = (shell.outer[1] - shell.outer[0]) / spacing
        self.bind(program, {**({} if texture.faces else {"u_texels": texture.dims, "u_origin": tuple(shell.origin)}),
                            "u_spacing": tuple(spacing),
                            "u_box_lo": tuple(lo), "u_box_hi": tuple(hi), "u_outer_lo": tuple(shell.outer[0]),
                            "u_outer_hi": tuple(shell.outer[1]), "u_corner": tuple(frame.origin),
                            "u_right": tuple(frame.right), "u_down": tuple(frame.down),
                            "u_forward": tuple(frame.forward),
                            "u_eye": tuple(np.asarray(scene.camera.eye, float)), "u_pixel": frame.image_pixel,
                            "u_cue": cue_line(scene), "u_weighted": tuple(cued), "u_nodes": list(nodes),
                            "u_node_weights": list(weights), "u_max_pieces": int(np.ceil(extent).sum()) + 4},
                  texture.textures)
        quad = self.ctx.vertex_array(program, [])
        quad.render(moderngl.TRIANGLES, vertices=3)
        quad.release()
        channels = data.shape[-1]
        # fragment row j is the image's row j from the top: read back as stored, not flipped
        raw = self.read(fbo, img.width, img.height, flip=False)
        return raw[..., :channels].astype(np.float64)

