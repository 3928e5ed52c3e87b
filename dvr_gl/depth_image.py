"""Depth images written beside the colour (``dvr render --depth``; docs/picking.md).

The depth is the distance along the view axis from the eye's plane, in world units (what OpenEXR's ``Z``
channel holds and compositing tools read as depth), ``inf`` where a ray has none (it misses, or its opacity
never reaches one half).  An EXR output takes it as a fifth channel named ``Z`` (channels R, G, B, A, Z);
PNG, JPEG and TIFF outputs get it in a side file, ``NAME.depth.exr`` (one channel, ``Z``); animations in one
file (GIF, MP4, ...) cannot hold it and are refused.  Every file is written under a temporary name and
renamed: an error leaves neither.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np

from .errors import DvrError
from .image import MOVIE_FORMATS, atomic_output, check_writable, write_image

SIDE_SUFFIX = ".depth.exr"


def side_path(output) -> Path | None:
    """Where the depth of ``output`` goes: None for EXR (its own Z channel), else ``NAME.depth.exr``."""
    output = Path(output)
    if output.suffix.lower() == ".exr":
        return None
    return output.with_name(output.stem + SIDE_SUFFIX)


def check_output(output, overwrite: bool = False, sequence: bool = False) -> Path | None:
    """Refuse, in one line and before any work, a depth that ``output`` cannot take; returns the side file
    (None for EXR).  ``sequence``: one of several numbered frames (side files are for single images)."""
    output = Path(output)
    suffix = output.suffix.lower()
    if suffix in MOVIE_FORMATS:
        raise DvrError(f"--depth: {suffix} animations hold no depth; write the frames as NAME_####.exr "
                       f"(a Z channel each), or leave out --depth")
    side = side_path(output)
    if side is not None and sequence:
        raise DvrError(f"--depth with --frames: write the frames as .exr (each with its Z channel), not {suffix}")
    if side is not None:
        check_writable(side, overwrite)
    return side


def write(output, rgba: np.ndarray, depth: np.ndarray, overwrite: bool = False):
    """Write ``rgba`` (linear, background composited; or 8-bit sRGB for the 8-bit formats) to ``output``
    with ``depth`` ``(H, W)``: as its Z channel (EXR) or into the side file; all or nothing."""
    output = Path(output)
    side = side_path(output)
    if side is None:
        _write_exr(output, np.concatenate([np.asarray(rgba, np.float32), depth[..., None]], axis=2),
                   ("R", "G", "B", "A", "Z"), overwrite)
        return
    with _exr_staged(side, depth[..., None], ("Z",), overwrite):
        write_image(output, rgba, overwrite)  # the side file is renamed into place only once this is written


def _write_exr(path: Path, pixels: np.ndarray, channels: tuple, overwrite: bool):
    with _exr_staged(path, pixels, channels, overwrite):
        pass  # written: renamed into place


@contextlib.contextmanager
def _exr_staged(path: Path, pixels: np.ndarray, channels: tuple, overwrite: bool):
    """Write a float EXR with named channels to a temporary file; renamed to ``path`` when the block ends
    without an error."""
    import OpenImageIO as oiio

    height, width, n = pixels.shape
    spec = oiio.ImageSpec(width, height, n, oiio.FLOAT)
    spec.channelnames = channels
    spec.alpha_channel = channels.index("A") if "A" in channels else -1
    spec.z_channel = channels.index("Z")
    buf = oiio.ImageBuf(spec)
    buf.set_pixels(oiio.ROI(), np.ascontiguousarray(pixels, np.float32))
    with atomic_output(path, overwrite) as tmp:
        if not buf.write(str(tmp), oiio.FLOAT):
            raise DvrError(f"{path}: writing failed ({buf.geterror().strip()})")
        yield


def read_z(path) -> np.ndarray:
    """The ``Z`` channel of an EXR file, ``(H, W)`` float32 (tests, and scripts that composite)."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(str(path))
    names = list(buf.spec().channelnames)
    if "Z" not in names:
        raise DvrError(f"{path}: has no Z channel (channels {', '.join(names)})")
    return np.asarray(buf.get_pixels(oiio.FLOAT))[..., names.index("Z")]
