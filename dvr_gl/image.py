"""Images: compositing over the background, writing through OpenImageIO, comparing.

Renderers produce premultiplied linear float32 RGBA.  The background is
composited once, here: ``out = C + (1 - A) * background`` (the background is
non-premultiplied RGBA).  EXR and TIFF keep linear float32 values; PNG and
JPEG are 8 bit, sRGB-encoded (OpenImageIO's colour conversion).  Files are
written to a temporary name in the target folder and renamed, so a failure
never leaves a partial file, and an existing file is replaced only when asked.
An output's folder must exist: it is never created (a mistyped folder is refused
before any work, in one line).

Animations (several frames in one file: :class:`Movie`) are 8-bit sRGB without
alpha: GIF through OpenImageIO, MP4 (H.264), WebM (VP9) and animated WebP through
PyAV, the optional extra ``video`` (its wheels carry FFmpeg's encoders).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np

from . import sandbox
from .errors import DvrError, install_hint

log = logging.getLogger(__name__)

FLOAT_FORMATS = (".exr", ".tif", ".tiff")
EIGHT_BIT_FORMATS = (".png", ".jpg", ".jpeg")
VIDEO_FORMATS = (".mp4", ".webm", ".webp")  # through PyAV (the optional extra 'video')
MOVIE_FORMATS = (".gif",) + VIDEO_FORMATS   # every frame of --frames in one file
FORMATS = FLOAT_FORMATS + EIGHT_BIT_FORMATS + MOVIE_FORMATS
DEFAULT_FPS = 25.0  # frames per second: exact in GIF, whose frame delays are whole hundredths of a second
# PyAV's encoder per suffix and its options: x264 at constant quality 18 (visually lossless for renderings;
# its default 23 bands smooth gradients), VP9 at constant quality 24, WebP lossless.
VIDEO_CODECS = {".mp4": ("libx264", {"crf": "18"}), ".webm": ("libvpx-vp9", {"crf": "24", "b": "0"}),
                ".webp": ("libwebp_anim", {"lossless": "1"})}


def composite_over(rgba: np.ndarray, background) -> np.ndarray:
    """Premultiplied ``rgba`` over a non-premultiplied ``background`` (r, g, b, a)."""
    bg = np.asarray(background, dtype=np.float32)
    bg_premult = np.concatenate([bg[:3] * bg[3], bg[3:4]])
    return rgba + (1.0 - rgba[..., 3:4]) * bg_premult


def side_by_side(pictures: list, axis: int = 1, gap: int = 4, background=(0.0, 0.0, 0.0, 1.0)) -> np.ndarray:
    """Premultiplied pictures of one height (``axis`` 1; of one width, stacked: ``axis`` 0) composited over
    ``background`` and joined with ``gap`` pixels of it between them: the docs' figures."""
    shape = list(pictures[0].shape)
    shape[axis] = gap
    spacer = composite_over(np.zeros(shape, np.float32), background)
    parts = []
    for p in pictures:
        parts += [composite_over(np.asarray(p, np.float32), background), spacer]
    return np.concatenate(parts[:-1], axis=axis)


def check_writable(path: Path, overwrite: bool = False) -> Path:
    """Fail early, before any work, if ``path`` cannot or must not be written."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    name_max = _name_max(folder)
    if len(os.fsencode(path.name)) > name_max:
        raise DvrError(f"{path.name[:40]}...: the output file name is {len(os.fsencode(path.name))} bytes, "
                       f"longer than the {name_max} the file system allows; choose a shorter name")
    sandbox.check_path_name(path, "output file")  # a NUL byte, a folder's name too long
    if path.is_dir():
        raise DvrError(f"{path}: is a folder; give a file name such as {path / 'image.png'}")
    sandbox.check_output_path(path)
    if path.exists() and not path.is_file():  # replacing /dev/... or a FIFO by a rename is never meant
        raise DvrError(f"{path}: exists and is not a regular file (a device, FIFO or socket); choose another name")
    if os.path.lexists(path) and not overwrite:  # a dangling or looping link too: the rename would replace it
        raise DvrError(f"{path}: exists; pass --overwrite to replace it, or choose another name")
    if not folder.is_dir():
        raise DvrError(f"{path}: folder {folder} does not exist; create it first (mkdir -p {folder}) "
                       f"or choose another output path")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise DvrError(f"{path}: folder {folder} is not writable; choose another output path")
    return path


def _name_max(folder: Path) -> int:
    """The longest file name (bytes) the folder's file system allows (255 where it does not say)."""
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        return 255


def check_output_path(path: Path, overwrite: bool = False) -> Path:
    """:func:`check_writable`, and the suffix must name an image format."""
    path = Path(path)
    if path.suffix.lower() not in FORMATS and not path.is_dir():
        raise DvrError(f"{path}: unsupported image format {path.suffix or '(none)'!r}; "
                       f"use one of {', '.join(FORMATS)}")
    return check_writable(path, overwrite)


def _file_mode(path: Path) -> int:
    """The mode of the file being replaced, or what the umask gives a new file."""
    if path.exists():
        return path.stat().st_mode & 0o7777
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_output(path: Path, overwrite: bool = False):
    """Yield a temporary file's path beside ``path`` to write; when the block ends without an error,
    rename it over ``path`` (else remove it). Callers check the path first (:func:`check_output_path`)."""
    path = sandbox.check_output_path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".dvr-", suffix=path.suffix, dir=folder)
    except OSError as exc:
        raise DvrError(f"{path}: cannot create a file in {folder} ({exc.strerror}); "
                       f"choose another output path") from exc
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, _file_mode(path))  # mkstemp makes private files; outputs are ordinary ones
        if os.path.lexists(path) and not overwrite:
            raise DvrError(f"{path}: appeared while rendering; not replaced (pass --overwrite)")
        os.replace(tmp, path)
    except OSError as exc:
        raise DvrError(f"{path}: writing failed ({exc.strerror or exc}); nothing was written") from exc
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def atomic_write(path: Path, write, overwrite: bool = False):
    """Call ``write(tmp_path)`` for a temporary file beside ``path``, then rename it over ``path``
    (callers check the path first: :func:`check_output_path`)."""
    with atomic_output(path, overwrite) as tmp:
        write(tmp)


def _encode(rgba: np.ndarray, suffix: str):
    import OpenImageIO as oiio

    if rgba.dtype == np.uint8:  # already 8-bit sRGB (an annotated picture: dvr_gl.annotations)
        if suffix not in EIGHT_BIT_FORMATS:
            raise DvrError(f"an 8-bit picture (annotated) is written to {', '.join(EIGHT_BIT_FORMATS)} or an "
                           f"animation, not {suffix}: the float formats hold the unannotated image")
        channels = (0, 1, 2) if suffix in (".jpg", ".jpeg") else tuple(range(rgba.shape[2]))
        return oiio.ImageBuf(np.ascontiguousarray(rgba[..., list(channels)])), oiio.UINT8
    buf = oiio.ImageBuf(np.ascontiguousarray(rgba, dtype=np.float32))
    if suffix in EIGHT_BIT_FORMATS:
        # Linear to sRGB; unpremult so colours of partly transparent pixels are converted right.
        buf = oiio.ImageBufAlgo.colorconvert(buf, "lin_rec709", "srgb_rec709_scene", unpremult=True)
        if buf.has_error:
            raise DvrError(f"colour conversion failed: {buf.geterror()}")
        if suffix in (".jpg", ".jpeg"):
            buf = oiio.ImageBufAlgo.channels(buf, (0, 1, 2))
        return buf, oiio.UINT8
    return buf, oiio.FLOAT


def encode_8bit(rgba: np.ndarray) -> np.ndarray:
    """Linear RGBA (background composited) as the 8-bit sRGB pixels a PNG file holds, ``(H, W, 4)`` uint8
    (uint8 pixels are taken as already encoded and returned as they are)."""
    import OpenImageIO as oiio

    if rgba.dtype == np.uint8:
        return rgba
    buf, _ = _encode(rgba, ".png")
    return np.asarray(buf.get_pixels(oiio.UINT8))


def write_image(path, rgba: np.ndarray, overwrite: bool = False):
    """Write linear RGBA (background already composited) to ``path``, atomically; uint8 ``rgba`` is 8-bit
    sRGB already (an annotated picture), for the 8-bit formats only."""
    path = Path(path)
    suffix = path.suffix.lower()
    check_output_path(path, overwrite)
    if suffix in MOVIE_FORMATS:  # an animation of one frame: 8-bit sRGB as every animation
        height, width = rgba.shape[:2]
        opacity = float(np.min(rgba[..., 3])) / (255.0 if rgba.dtype == np.uint8 else 1.0)
        check_movie(path, width, height, DEFAULT_FPS, (0.0, 0.0, 0.0, opacity))
        with Movie(path, 1, overwrite=overwrite) as movie:
            movie.add(rgba)
        return
    buf, fmt = _encode(rgba, suffix)

    def write(tmp: Path):
        if not buf.write(str(tmp), fmt):
            raise DvrError(f"{path}: writing failed ({buf.geterror().strip()})")

    atomic_write(path, write, overwrite)


def have_video() -> bool:
    """Whether PyAV (the optional extra ``video``) is installed."""
    try:
        import av  # noqa: F401
    except ImportError:
        return False
    return True


def check_movie(path: Path, width: int, height: int, fps: float, background=(0.0, 0.0, 0.0, 1.0)):
    """Refuse, before any rendering, an animation that could not be written as asked (one line each)."""
    suffix = Path(path).suffix.lower()
    if not (math.isfinite(fps) and fps > 0):
        raise DvrError(f"--fps {fps:g}: give a positive number of frames per second")
    if suffix == ".gif" and fps > 50:
        # GIF stores each frame's delay in whole hundredths of a second, and viewers show delays
        # below 2 as 10: faster GIFs play slower, not faster.
        raise DvrError(f"--fps {fps:g}: GIF frames last whole hundredths of a second and viewers slow down "
                       f"frames shorter than 0.02 s; use --fps 50 or less, or .mp4")
    if suffix in VIDEO_FORMATS and not have_video():
        raise DvrError(f"{path}: writing {suffix} needs PyAV, the optional extra 'video': "
                       f"{install_hint('video')}; or write .gif, or frames as .png")
    if suffix == ".mp4" and (width % 2 or height % 2):
        raise DvrError(f"{path}: H.264 (4:2:0) needs an even width and height, got {width}x{height}; "
                       f"use e.g. --size {width + width % 2}x{height + height % 2}")
    if len(background) > 3 and background[3] < 1.0:
        raise DvrError(f"{path}: {suffix} frames have no partial transparency; give an opaque background "
                       f"(alpha 1) or write frames as .png")


class Movie:
    """Frames written one at a time into one animated file, atomically: ``with Movie(...) as m:
    m.add(rgba)``; the file appears when the block ends with every frame added, never otherwise.

    Frames are linear RGBA with the background composited (:func:`composite_over`), encoded to 8-bit
    sRGB as for PNG, alpha dropped (:func:`check_movie` asks for an opaque background).
    """

    def __init__(self, path, frames: int, fps: float = DEFAULT_FPS, overwrite: bool = False):
        self.path, self.frames, self.fps, self.overwrite = Path(path), frames, fps, overwrite
        self.suffix = self.path.suffix.lower()
        if self.suffix not in MOVIE_FORMATS:
            raise DvrError(f"{path}: not an animation format; use one of {', '.join(MOVIE_FORMATS)}")
        self.added = 0
        self._output = self._writer = None

    def __enter__(self):
        check_writable(self.path, self.overwrite)
        self._stack = contextlib.ExitStack()
        self._tmp = self._stack.enter_context(atomic_output(self.path, self.overwrite))
        return self

    def add(self, rgba: np.ndarray):
        """Append a frame (linear RGBA over the background, ``(H, W, 4)``; or uint8, 8-bit sRGB already)."""
        if self.added >= self.frames:
            raise ValueError(f"{self.path}: all {self.frames} frames were added")
        rgb = encode_8bit(rgba)[..., :3]
        if self._writer is None:
            open_ = _GifWriter if self.suffix == ".gif" else _VideoWriter
            self._writer = open_(self._tmp, rgb.shape[1], rgb.shape[0], self.frames, self.fps, self.suffix)
        self._writer.add(rgb)
        self.added += 1

    def __exit__(self, kind, exc, tb):
        if kind is None:
            with self._stack:  # renamed into place at the end; removed if finishing fails
                if self.added != self.frames:
                    raise DvrError(f"{self.path}: {self.added} of {self.frames} frames were rendered; "
                                   f"nothing was written")
                self._writer.close(failed=False)
        else:
            try:
                if self._writer is not None:
                    self._writer.close(failed=True)
            finally:
                self._stack.__exit__(kind, exc, tb)  # the temporary file removed
        return False


class _GifWriter:
    """A multi-image GIF through OpenImageIO (its frames' subimages appended one by one)."""

    def __init__(self, tmp: Path, width: int, height: int, frames: int, fps: float, suffix: str):
        import OpenImageIO as oiio

        self.oiio, self.tmp = oiio, tmp
        rate = Fraction(fps).limit_denominator(1000)
        spec = oiio.ImageSpec(width, height, 3, oiio.UINT8)
        spec.attribute("FramesPerSecond", oiio.TypeDesc("rational"), (rate.numerator, rate.denominator))
        spec.attribute("oiio:Movie", 1)
        spec.attribute("gif:LoopCount", 0)  # loop forever
        self.spec, self.out = spec, oiio.ImageOutput.create(str(tmp))
        if self.out is None or not self.out.open(str(tmp), [spec] * frames):
            raise DvrError(f"cannot write GIF: {oiio.geterror() if self.out is None else self.out.geterror()}")
        self.count = 0
        log.debug("GIF at %g frames per second (a delay of %d hundredths of a second)", fps, round(100 / fps))

    def add(self, rgb: np.ndarray):
        if self.count and not self.out.open(str(self.tmp), self.spec, "AppendSubimage"):
            raise DvrError(f"cannot append a GIF frame: {self.out.geterror()}")
        if not self.out.write_image(np.ascontiguousarray(rgb)):
            raise DvrError(f"cannot write a GIF frame: {self.out.geterror()}")
        self.count += 1

    def close(self, failed: bool):
        if not self.out.close() and not failed:
            raise DvrError(f"cannot finish the GIF: {self.out.geterror()}")


class _VideoWriter:
    """MP4, WebM or animated WebP through PyAV (FFmpeg's encoders)."""

    def __init__(self, tmp: Path, width: int, height: int, frames: int, fps: float, suffix: str):
        import av

        self.av = av
        codec, options = VIDEO_CODECS[suffix]
        try:
            self.container = av.open(str(tmp), mode="w")
            self.stream = self.container.add_stream(codec, rate=Fraction(fps).limit_denominator(1000),
                                                    options=dict(options))
            self.stream.width, self.stream.height = width, height
            self.stream.pix_fmt = "yuv420p"
        except av.FFmpegError as exc:
            raise DvrError(f"cannot write {suffix} with {codec}: {exc}") from None
        self.suffix = suffix

    def add(self, rgb: np.ndarray):
        frame = self.av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
        try:
            for packet in self.stream.encode(frame):
                self.container.mux(packet)
        except self.av.FFmpegError as exc:
            raise DvrError(f"encoding a {self.suffix} frame failed: {exc}") from None

    def close(self, failed: bool):
        try:
            if not failed:
                for packet in self.stream.encode():  # flush the encoder's delayed frames
                    self.container.mux(packet)
        except self.av.FFmpegError as exc:
            raise DvrError(f"finishing the {self.suffix} file failed: {exc}") from None
        finally:
            self.container.close()


def write_text(path, text: str, overwrite: bool = False):
    """Write a text file atomically (the effective scene), refusing to replace unless asked."""
    atomic_write(check_writable(Path(path), overwrite), lambda tmp: tmp.write_text(text, encoding="utf-8"),
                 overwrite)


def read_image(path) -> np.ndarray:
    """An image file as float32 ``(H, W, C)`` (8-bit files are decoded to [0, 1], not linearized)."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(str(path))
    pixels = buf.get_pixels(oiio.FLOAT)
    if buf.has_error or pixels is None:
        raise DvrError(f"{path}: cannot read image ({buf.geterror().strip()})")
    return np.asarray(pixels)


def compare_images(a: np.ndarray, b: np.ndarray) -> dict:
    """Error of image ``a`` against ``b`` (same shape, linear float) with OpenImageIO:
    mean absolute, RMS and maximum error over all channels, and PSNR (peak 1)."""
    import OpenImageIO as oiio

    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} vs {b.shape}")
    ba = oiio.ImageBuf(np.ascontiguousarray(a, dtype=np.float32))
    bb = oiio.ImageBuf(np.ascontiguousarray(b, dtype=np.float32))
    r = oiio.ImageBufAlgo.compare(ba, bb, 0.0, 0.0)
    # PSNR for a peak of 1 (OpenImageIO's own uses the images' largest value, which moves with the error)
    psnr = float("inf") if r.rms_error == 0 else -20.0 * math.log10(r.rms_error)
    return {"mean": r.meanerror, "rms": r.rms_error, "max": r.maxerror, "psnr": psnr}
