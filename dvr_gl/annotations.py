"""Annotations: a colour bar, a scale bar, orientation axes and a caption drawn over the 8-bit picture.

They are drawn onto the 8-bit sRGB pixels a PNG holds (:func:`dvr_gl.image.encode_8bit`), never into the
float image: the renderers' premultiplied linear RGBA, EXR and TIFF outputs stay measurements of the
volume.  An annotated picture is therefore 8-bit only (``.png``, ``.jpg``, an animation).  Each
annotation owns a box (:func:`layout`) on a translucent dark panel; no pixel outside the boxes changes.

* ``colorbar``: the transfer function's colour column (non-associated linear RGB, sRGB-encoded as the
  image is) over its domain, top = highest value, with tick labels in the data's units (``HU`` for a
  CT transfer function: a CT preset or a non-zero ``rescale_intercept``, labelled ``data +
  intercept``; else ``value``); to its right the opacity column, a white profile whose width at each
  value is the square root of the opacity there (alpha per unit distance, or extinction, by the transfer
  function's model) over that of the largest on the bar: the square root keeps the faint bands that
  volume rendering lives on visible beside an opaque one (a 2D transfer function: its value marginal,
  each value's most opaque node).
* ``scalebar``: a round world length (1, 2 or 5 times a power of ten) of about a fifth of the image's
  width, measured in the plane through the target perpendicular to the view (exact for orthographic
  views; perspective views shrink what lies behind the target and grow what lies in front).  Its unit:
  ``mm`` where the file states a patient orientation (DICOM, NIfTI, NRRD ``space``, MetaImage: their
  standards measure in millimetres), else none (world units).
* ``axes``: a triad of the world axes turned as the camera turns them, labelled with the patient
  direction each points to (``L``, ``P``, ``S``: the LPS frame, docs/orientation.md) when the file
  states an orientation, else ``x``, ``y``, ``z``.
* ``caption``: one line of text, top left.

Text is set by OpenImageIO's ``render_text`` in a TrueType font: its own wheel ships the Droid fonts
(found with only the base dependencies); where no font is found the call fails in one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import DvrError
from .image import encode_8bit
from .orientation import is_oriented

ITEMS = ("colorbar", "scalebar", "axes")
FONT = "DroidSans"  # in OpenImageIO's wheel; DejaVuSans and the system's fonts as fallbacks
FALLBACK_FONTS = ("DejaVuSans", "LiberationSans-Regular", "Arial")
PANEL_ALPHA = 0.55  # the dark panel's opacity behind each annotation (legible on white and black)
AXIS_COLOURS = ((235, 80, 70), (90, 200, 90), (90, 150, 255))  # x, y, z in sRGB8


@dataclass(frozen=True)
class Annotations:
    """What to draw.  ``length_unit`` / ``value_unit``: None for the default described above."""

    colorbar: bool = False
    scalebar: bool = False
    axes: bool = False
    caption: str | None = None
    length_unit: str | None = None
    value_unit: str | None = None

    def __bool__(self) -> bool:
        return self.colorbar or self.scalebar or self.axes or bool(self.caption)


def parse_annotate(text: str) -> Annotations:
    """``--annotate``: comma-separated ``colorbar``, ``scalebar``, ``axes``, ``all``, ``caption=TEXT`` (last:
    it takes the rest of the text, commas included), ``unit=TEXT``, ``value_unit=TEXT``."""
    items, caption, units = set(), None, {}
    rest = text
    while rest:
        part, _, rest = rest.partition(",")
        key, sep, value = part.partition("=")
        key = key.strip().lower()
        if key == "caption" and sep:
            caption = (value + ("," + rest if rest else "")).strip()
            break
        if key in ("unit", "value_unit") and sep and value.strip():
            units["length_unit" if key == "unit" else "value_unit"] = value.strip()
        elif key == "all" and not sep:
            items.update(ITEMS)
        elif key in ITEMS and not sep:
            items.add(key)
        elif key:
            raise ValueError(f"--annotate {text!r}: {part.strip()!r} is not one of {', '.join(ITEMS)}, all, "
                             f"caption=TEXT, unit=TEXT, value_unit=TEXT")
    if not items and not caption:
        raise ValueError(f"--annotate {text!r}: name what to draw: {', '.join(ITEMS)}, all or caption=TEXT")
    return Annotations(**{k: k in items for k in ITEMS}, caption=caption, **units)


# --- measurements --------------------------------------------------------------------------------------


def pixel_size(camera, height: int) -> float:
    """World length of one pixel in the plane through the target perpendicular to the view (world units)."""
    if camera.projection == "orthographic":
        return camera.view_height / height
    distance = float(np.linalg.norm(np.subtract(camera.target, camera.eye)))
    return 2.0 * distance * math.tan(math.radians(camera.fov) / 2.0) / height


def round_length(length: float) -> float:
    """The 1, 2 or 5 times a power of ten nearest to ``length`` (> 0) in ratio."""
    power = 10.0 ** math.floor(math.log10(length))
    return min((m * power for m in (1.0, 2.0, 5.0, 10.0)), key=lambda v: abs(math.log(v / length)))


def scale_bar(scene) -> tuple[float, float]:
    """``(world length, length in pixels)`` of the scale bar: a round length near a fifth of the width."""
    size = pixel_size(scene.camera, scene.image.height)
    world = round_length(scene.image.width / 5.0 * size)
    return world, world / size


def length_unit(scene, given: str | None = None) -> str:
    if given is not None:
        return given
    return "mm" if is_oriented(scene.field) else ""


def value_units(scene, given: str | None = None) -> tuple[str, float]:
    """``(unit, offset)``: the colour bar labels ``value + offset`` in ``unit``."""
    spec = getattr(getattr(scene, "spec", None), "transfer_function", None)
    intercept = float(getattr(spec, "rescale_intercept", 0.0) or 0.0)
    ct = intercept != 0.0 or str(getattr(spec, "preset", "") or "").lower().startswith("ct")
    if given is not None:
        return given, intercept if ct else 0.0
    return ("HU", intercept) if ct else ("value", 0.0)


def nice_ticks(lo: float, hi: float, count: int = 5) -> np.ndarray:
    """Round values (1, 2 or 5 times a power of ten apart) in ``[lo, hi]``, about ``count`` of them."""
    if not hi > lo:
        return np.array([lo])
    step = round_length((hi - lo) / max(count - 1, 1))
    first = math.ceil(lo / step - 1e-9) * step
    return np.arange(first, hi + step * 1e-9, step)


def axis_tips(camera) -> np.ndarray:
    """``(3, 3)``: each world axis (x, y, z) projected on the image: ``(right, down, toward the eye)``
    components, from the camera's rotation alone (an orientation triad's arms)."""
    forward, right, up = camera.basis()
    axes = np.eye(3)
    return np.stack([axes @ right, -(axes @ up), -(axes @ forward)], axis=1)


def axis_labels(scene) -> tuple[str, str, str]:
    return ("L", "P", "S") if is_oriented(scene.field) else ("x", "y", "z")


# --- layout and drawing --------------------------------------------------------------------------------


def font_size(height: int) -> int:
    return max(9, round(height / 28))


def layout(scene, annotations: Annotations) -> dict[str, tuple[int, int, int, int]]:
    """Each annotation's box ``(x0, y0, x1, y1)`` in pixels (exclusive ends); refused in one line when one
    does not fit in the image."""
    w, h = scene.image.width, scene.image.height
    f = font_size(h)
    m = max(2, f // 3)  # margin
    boxes = {}
    if annotations.caption:
        tw, th = _text_extent(annotations.caption, f)
        boxes["caption"] = (m, m, m + tw + 2 * m, m + th + 2 * m)
    if annotations.axes:
        s = 5 * f
        boxes["axes"] = (m, h - m - s, m + s, h - m)
    if annotations.scalebar:
        _, pixels = scale_bar(scene)
        bw = int(round(pixels)) + 2 * m
        boxes["scalebar"] = (w - m - bw, h - m - 2 * f - 2 * m, w - m, h - m)
    if annotations.colorbar:
        labels = _colorbar_labels(scene, annotations)
        tw = max(_text_extent(t, f)[0] for _, t in labels)
        title_w = _text_extent(value_units(scene, annotations.value_unit)[0], f)[0]
        bw = max(tw + 2 * f + 4 * m, title_w + 2 * m)
        bottom = boxes["scalebar"][1] - m if "scalebar" in boxes else h - m
        top = max(m, bottom - int(0.6 * h))
        boxes["colorbar"] = (w - m - bw, top, w - m, bottom)
        strip = colorbar_geometry(boxes["colorbar"], f)
        if strip[3] - strip[1] < 2 * f or strip[0] < boxes["colorbar"][0]:
            raise DvrError(f"annotate colorbar: a {w}x{h} image has no room for it; render at least 96 pixels "
                           f"high, or drop colorbar")
    for name, (x0, y0, x1, y1) in boxes.items():
        if x0 < 0 or y0 < 0 or x1 > w or y1 > h or x1 <= x0 or y1 <= y0:
            raise DvrError(f"annotate {name}: a {w}x{h} image has no room for it; render a larger image or drop "
                           f"{name}")
    return boxes


def annotate(pixels, scene=None, annotations: Annotations | None = None, **items) -> np.ndarray:
    """``pixels`` (8-bit sRGB ``(H, W, 3 or 4)``, as :func:`dvr_gl.image.encode_8bit` gives) with the
    annotations drawn over them, a new array; ``scene``: the scene the picture shows (its camera, field,
    transfer function and image size).  ``pixels`` may be a :class:`dvr_gl.Image` (its :meth:`srgb8` and
    scene); ``items``: :class:`Annotations`' fields, instead of ``annotations``
    (``annotate(image, axes=True, caption="CT")``)."""
    if hasattr(pixels, "srgb8") and hasattr(pixels, "scene"):
        scene = scene if scene is not None else pixels.scene
        pixels = pixels.srgb8()
    if scene is None:
        raise DvrError("annotate: give the scene the pixels show (its camera, field and transfer function)")
    annotations = annotations if annotations is not None else Annotations(**items)
    out = np.array(pixels, dtype=np.uint8, copy=True)
    if out.ndim != 3 or out.shape[:2] != (scene.image.height, scene.image.width):
        raise DvrError(f"annotate: the pixels are {out.shape}, the scene's image {scene.image.width}x"
                       f"{scene.image.height}; annotate the picture of that scene")
    f = font_size(scene.image.height)
    for name, box in layout(scene, annotations).items():
        _panel(out, box)
        _DRAW[name](out, box, scene, annotations, f)
    return out


def _panel(out, box):
    x0, y0, x1, y1 = box
    region = out[y0:y1, x0:x1, :3].astype(np.float32)
    out[y0:y1, x0:x1, :3] = np.round(region * (1.0 - PANEL_ALPHA)).astype(np.uint8)
    if out.shape[2] == 4:
        out[y0:y1, x0:x1, 3] = 255


def _draw_caption(out, box, scene, annotations, f):
    m = max(2, f // 3)
    _text(out, box, annotations.caption, box[0] + m, box[1] + m, f)


def _draw_scalebar(out, box, scene, annotations, f):
    world, pixels = scale_bar(scene)
    m = max(2, f // 3)
    x0, y1 = box[0] + m, box[3] - m
    n = int(round(pixels))
    thick = max(2, f // 5)
    out[y1 - thick:y1, x0:x0 + n, :3] = 255
    unit = length_unit(scene, annotations.length_unit)
    label = f"{world:g} {unit}".strip()
    tw, _ = _text_extent(label, f)
    _text(out, box, label, x0 + max(0, (n - tw) // 2), box[1] + m, f)


def colorbar_geometry(box, f) -> tuple[int, int, int, int]:
    """The colour strip's ``(x0, y0, x1, y1)`` inside the colour bar's box (left of the opacity column)."""
    m = max(2, f // 3)
    x1 = box[2] - 2 * m - f
    return x1 - f, box[1] + 2 * m + f + f // 2 + 1, x1, box[3] - m - f // 2  # below the unit, half a line


def opacity_geometry(box, f) -> tuple[int, int, int, int]:
    """The opacity column's ``(x0, y0, x1, y1)``: beside the colour strip, its rows at the strip's values."""
    m = max(2, f // 3)
    _, y0, x1, y1 = colorbar_geometry(box, f)
    return x1 + m, y0, x1 + m + f, y1


def opacity_profile(scene, strip) -> np.ndarray:
    """Each row's profile width in [0, 1]: the square root of its opacity over the largest on the bar (zeros
    where the bar is transparent)."""
    opacity = np.asarray(scene.transfer_function.opacity(colorbar_values(scene, strip)), dtype=np.float64)
    top = float(opacity.max(initial=0.0))
    return np.sqrt(opacity / top) if top > 0 else np.zeros_like(opacity)


def colorbar_values(scene, strip) -> np.ndarray:
    """The data value each row of the strip shows, top row highest (pixel centres, linear)."""
    lo, hi = _domain(scene)
    _, y0, _, y1 = strip
    rows = np.arange(y1 - y0)
    return hi - (rows + 0.5) / (y1 - y0) * (hi - lo)


def _domain(scene):
    tf = scene.transfer_function
    if not hasattr(tf, "color") or not hasattr(tf, "domain"):
        raise DvrError("annotate colorbar: this scene's transfer function (a label table or a 2D one) has no "
                       "single colour scale; drop colorbar")
    return tuple(float(v) for v in tf.domain)


def _colorbar_labels(scene, annotations):
    lo, hi = _domain(scene)
    _, offset = value_units(scene, annotations.value_unit)
    ticks = nice_ticks(lo + offset, hi + offset)
    return [(t - offset, f"{t:.4g}") for t in ticks]


def _draw_colorbar(out, box, scene, annotations, f):
    m = max(2, f // 3)
    strip = colorbar_geometry(box, f)
    sx0, sy0, sx1, sy1 = strip
    values = colorbar_values(scene, strip)
    rgb = np.asarray(scene.transfer_function.color(values), dtype=np.float32)
    rgba = np.concatenate([rgb, np.ones((len(rgb), 1), np.float32)], axis=1)[:, None, :]
    colours = encode_8bit(np.clip(rgba, 0.0, None))[:, 0, :3]
    out[sy0:sy1, sx0:sx1, :3] = colours[:, None, :]
    _draw_opacity(out, opacity_geometry(box, f), scene)
    lo, hi = _domain(scene)
    for value, label in _colorbar_labels(scene, annotations):
        y = sy0 + int(round((hi - value) / (hi - lo) * (sy1 - sy0))) if hi > lo else sy0
        y = min(max(y, sy0), sy1 - 1)
        out[y, sx0 - m:sx0, :3] = 255
        tw, th = _text_extent(label, f)
        _text(out, box, label, sx0 - m - 2 - tw, y - th // 2, f)
    unit, _ = value_units(scene, annotations.value_unit)
    _text(out, box, unit, box[0] + m, box[1] + m, f)


def _draw_opacity(out, column, scene):
    """The opacity profile: each row white from the column's left edge over its share of the width, beyond it
    the panel with a dim line at the right edge (the largest opacity), and a grey line at the left (zero)."""
    x0, y0, x1, y1 = column
    filled = np.round(opacity_profile(scene, column) * (x1 - x0)).astype(int)
    inside = np.arange(x1 - x0)[None, :] < filled[:, None]
    region = out[y0:y1, x0:x1, :3]
    region[:, -1] = 110
    region[inside] = 255
    region[:, 0] = np.maximum(region[:, 0], 160)


def _draw_axes(out, box, scene, annotations, f):
    x0, y0, x1, y1 = box
    centre = np.array([(x0 + x1) / 2.0, (y0 + y1) / 2.0])
    arm = 0.3 * (x1 - x0)
    tips = axis_tips(scene.camera)
    for k in np.argsort(tips[:, 2]):  # farthest first: the nearer arms drawn over them
        end = centre + arm * tips[k, :2]
        _line(out, box, centre, end, AXIS_COLOURS[k], max(1, f // 6))
        label = axis_labels(scene)[k]
        tw, th = _text_extent(label, f)
        at = centre + (arm + 0.45 * f) * tips[k, :2]
        _text(out, box, label, int(at[0] - tw / 2), int(at[1] - th / 2), f, AXIS_COLOURS[k])


_DRAW = {"caption": _draw_caption, "scalebar": _draw_scalebar, "colorbar": _draw_colorbar, "axes": _draw_axes}


def _line(out, box, a, b, colour, width: int):
    """A line from ``a`` to ``b`` (pixel coordinates), ``width`` pixels wide, kept inside ``box``."""
    n = int(max(abs(b[0] - a[0]), abs(b[1] - a[1]))) + 1
    x0, y0, x1, y1 = box
    for t in np.linspace(0.0, 1.0, n):
        p = a + t * (b - a)
        xs = slice(max(x0, int(p[0]) - width // 2), min(x1, int(p[0]) - width // 2 + width))
        ys = slice(max(y0, int(p[1]) - width // 2), min(y1, int(p[1]) - width // 2 + width))
        out[ys, xs, :3] = colour


# --- text ----------------------------------------------------------------------------------------------

_font_cache: dict = {}


def font() -> str:
    """The first font OpenImageIO finds among :data:`FONT` and :data:`FALLBACK_FONTS`; one line if none."""
    if "name" not in _font_cache:
        import OpenImageIO as oiio

        probe = oiio.ImageBuf(oiio.ImageSpec(8, 8, 3, oiio.UINT8))
        for name in (FONT,) + FALLBACK_FONTS:
            if oiio.ImageBufAlgo.render_text(probe, 0, 6, "x", 6, name):
                _font_cache["name"] = name
                break
        else:
            raise DvrError("annotations need a TrueType font and OpenImageIO found none (its wheel ships Droid "
                           "Sans; this build does not): install one, e.g. apt install fonts-dejavu-core, or set "
                           "OPENIMAGEIO_FONTS to a folder of .ttf files")
    return _font_cache["name"]


def _text_extent(text: str, size: int) -> tuple[int, int]:
    """``(width, height)`` in pixels of ``text`` set at ``size`` (the line's height: the font size)."""
    import OpenImageIO as oiio

    roi = oiio.ImageBufAlgo.text_size(text, size, font())
    return max(0, roi.xend - roi.xbegin), size


def _text(out, box, text: str, x: int, y: int, size: int, colour=(255, 255, 255)):
    """``text`` with its line's top-left at ``(x, y)``, drawn only inside ``box``."""
    import OpenImageIO as oiio

    x0, y0, x1, y1 = box
    region = np.ascontiguousarray(out[y0:y1, x0:x1])
    buf = oiio.ImageBuf(region)
    baseline = y - y0 + int(round(0.8 * size))
    rgba = tuple(c / 255.0 for c in colour) + (1.0,) * (region.shape[2] - 3)
    if not oiio.ImageBufAlgo.render_text(buf, x - x0, baseline, text, size, font(), rgba[:region.shape[2]]):
        raise DvrError(f"annotate: drawing the text {text[:30]!r} failed: {buf.geterror() or oiio.geterror()}")
    out[y0:y1, x0:x1] = np.asarray(buf.get_pixels(oiio.UINT8)).reshape(region.shape)
