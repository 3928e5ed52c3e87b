"""Screenshots: the full-quality image and the effective scene, under the first free number.

The image is written exactly as ``dvr render`` writes it (background composited once,
:func:`dvr_gl.image.write_image`: sRGB 8-bit PNG, or linear float EXR/TIFF), and beside it the
effective scene (:meth:`dvr_gl.scene.resolve.Scene.to_toml`, paths relative to the file), so
``dvr render dvr_view_0001.toml -o again.png`` repeats the image.  Nothing is ever replaced.  With
annotations on (A), an 8-bit image (.png, .jpg) is written annotated (:func:`dvr_gl.annotations.annotate`);
a float image (.exr, .tif) never is.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DvrError
from ..image import FLOAT_FORMATS, FORMATS, composite_over, encode_8bit, write_image, write_text

PREFIX = "dvr_view_"


def next_paths(folder: Path, suffix: str = ".png", prefix: str = PREFIX) -> tuple[Path, Path]:
    """``(image, scene)`` paths ``PREFIXnnnn.suffix`` and ``PREFIXnnnn.toml`` with the first number
    ``nnnn`` (from 1) for which neither file exists."""
    folder = Path(folder)
    if suffix.lower() not in FORMATS:
        raise DvrError(f"screenshot format {suffix!r} is not one of {', '.join(FORMATS)}")
    n = 1
    while True:
        image, scene = folder / f"{prefix}{n:04d}{suffix}", folder / f"{prefix}{n:04d}.toml"
        if not image.exists() and not scene.exists():
            return image, scene
        n += 1


def write_screenshot(scene, rgba: np.ndarray, folder: Path, suffix: str = ".png",
                     annotations=None) -> tuple[Path, Path]:
    """Write the renderer's image ``rgba`` (premultiplied, no background) of ``scene`` and the scene;
    ``annotations`` (:class:`dvr_gl.annotations.Annotations`): drawn over an 8-bit image only."""
    image_path, scene_path = next_paths(folder, suffix)
    picture = composite_over(rgba, scene.image.background)
    if annotations and suffix.lower() not in FLOAT_FORMATS:
        from ..annotations import annotate

        picture = annotate(encode_8bit(picture), scene, annotations)
    write_image(image_path, picture, overwrite=False)
    write_text(scene_path, scene.to_toml(relative_to=scene_path.resolve().parent), overwrite=False)
    return image_path, scene_path
