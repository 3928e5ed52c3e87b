"""Images: compositing over the background, writing through OpenImageIO, comparing.

Renderers produce premultiplied linear float32 RGBA.  The background is
composited once, here: ``out = C + (1 - A) * background`` (the background is
non-premultiplied RGBA).  EXR and TIFF keep linear float32 values; PNG and
JPEG are 8 bit, sRGB-encoded (OpenImageIO's colour conversion).  Files are
written to a temporary name in the target folder and renamed, so a failure
never leaves a partial file, and an existing file is replaced only when asked.
"""

from __future__ import annotations

import math

import os
import tempfile
from pathlib import Path

import numpy as np

from . import sandbox
from .errors import DvrError

FLOAT_FORMATS = (".exr", ".tif", ".tiff")
EIGHT_BIT_FORMATS = (".png", ".jpg", ".jpeg")
FORMATS = FLOAT_FORMATS + EIGHT_BIT_FORMATS


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
    if path.is_dir():
        raise DvrError(f"{path}: is a folder; give a file name such as {path / 'image.png'}")
    sandbox.check_output_path(path)
    if path.exists() and not path.is_file():  # replacing /dev/... or a FIFO by a rename is never meant
        raise DvrError(f"{path}: exists and is not a regular file (a device, FIFO or socket); choose another name")
    if path.exists() and not overwrite:
        raise DvrError(f"{path}: exists; pass --overwrite to replace it, or choose another name")
    if not folder.is_dir():
        raise DvrError(f"{path}: folder {folder} does not exist; create it first")
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


def atomic_write(path: Path, write, overwrite: bool = False):
    """Call ``write(tmp_path)`` for a temporary file beside ``path``, then rename it over ``path``
    (callers check the path first: :func:`check_output_path`)."""
    path = sandbox.check_output_path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".dvr-", suffix=path.suffix, dir=folder)
    except OSError as exc:
        raise DvrError(f"{path}: cannot create a file in {folder} ({exc.strerror}); "
                       f"choose another output path") from exc
    os.close(fd)
    try:
        write(Path(tmp))
        os.chmod(tmp, _file_mode(path))  # mkstemp makes private files; outputs are ordinary ones
        if path.exists() and not overwrite:
            raise DvrError(f"{path}: appeared while rendering; not replaced (pass --overwrite)")
        os.replace(tmp, path)
    except OSError as exc:
        raise DvrError(f"{path}: writing failed ({exc.strerror or exc}); nothing was written") from exc
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _encode(rgba: np.ndarray, suffix: str):
    import OpenImageIO as oiio

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
    """Linear RGBA (background composited) as the 8-bit sRGB pixels a PNG file holds, ``(H, W, 4)`` uint8."""
    import OpenImageIO as oiio

    buf, _ = _encode(rgba, ".png")
    return np.asarray(buf.get_pixels(oiio.UINT8))


def write_image(path, rgba: np.ndarray, overwrite: bool = False):
    """Write linear RGBA (background already composited) to ``path``, atomically."""
    path = Path(path)
    suffix = path.suffix.lower()
    check_output_path(path, overwrite)
    buf, fmt = _encode(rgba, suffix)

    def write(tmp: Path):
        if not buf.write(str(tmp), fmt):
            raise DvrError(f"{path}: writing failed ({buf.geterror().strip()})")

    atomic_write(path, write, overwrite)


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
