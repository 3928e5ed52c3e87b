"""Where things go in the viewer's window (pure; no window).

All rectangles are ``(x, y, width, height)`` in window pixels (screen coordinates: x to the right,
y down from the window's top left), as GLFW reports the cursor and ImGui draws.

The window holds three parts that never overlap:

* the **status bar** (the HUD), across the whole width at the bottom, :data:`STATUS_HEIGHT`
  pixels (two lines of text), absent when hidden (H) or without the GUI (then the HUD is in the
  window's title);
* the **side panel** on the right above it, :data:`PANEL_WIDTH` pixels, absent when hidden (Tab)
  or without the GUI;
* the **render area**, the rest (top left), where the image is drawn.

The image fills the render area when its size follows the window (the demo, a volume file,
``--size``: the render size is the area's size in framebuffer pixels).  A scene file's image
keeps the file's own size (what ``dvr render`` of the file makes) and is drawn scaled to fit
the area, its aspect kept, centred (:func:`fit`).
"""

from __future__ import annotations

from dataclasses import dataclass

PANEL_WIDTH = 360     # window pixels
HELP_MARGIN = 8       # window pixels between the help overlay and the window's edges (at most)
STATUS_HEIGHT = 40    # window pixels: two lines of ImGui's 13-pixel font, 4-pixel spacing and padding
MIN_AREA = 512        # the render area's default side, and the least height a scene file's window gets

Rect = tuple[float, float, float, float]


@dataclass(frozen=True)
class Layout:
    """The window's parts (see the module doc); ``panel`` and ``status`` are None when absent."""

    window: tuple[int, int]
    area: Rect
    image: Rect
    panel: Rect | None
    status: Rect | None


def fit(size: tuple[int, int], area: Rect) -> Rect:
    """The largest rectangle of ``size``'s aspect inside ``area``, centred (scaled up or down)."""
    x, y, w, h = area
    iw, ih = size
    if iw <= 0 or ih <= 0:
        fw = fh = 0.0
    elif w * ih <= h * iw:       # width-limited: exactly the area's width (no rounding past its edge)
        fw, fh = float(w), ih * w / iw
    else:
        fw, fh = iw * h / ih, float(h)
    return (x + (w - fw) / 2, y + (h - fh) / 2, fw, fh)


def layout(window: tuple[int, int], panel: bool, status: bool, image: tuple[int, int] | None = None) -> Layout:
    """The parts of a ``window`` (width, height) in window pixels; ``image``: the size of an image
    drawn scaled to fit (None: the image fills the render area)."""
    win_w, win_h = max(0, int(window[0])), max(0, int(window[1]))
    bar = min(STATUS_HEIGHT, win_h) if status else 0
    side = min(PANEL_WIDTH, win_w) if panel else 0
    area = (0.0, 0.0, float(win_w - side), float(win_h - bar))
    return Layout(
        window=(win_w, win_h),
        area=area,
        image=area if image is None else fit(image, area),
        panel=(float(win_w - side), 0.0, float(side), float(win_h - bar)) if panel else None,
        status=(0.0, float(win_h - bar), float(win_w), float(bar)) if status else None,
    )


def window_size(image: tuple[int, int], panel: bool, status: bool, fit_image: bool,
                limit: tuple[int, int] | None = None) -> tuple[int, int]:
    """The window's size at start, window pixels.

    When the image follows the window, its render area is ``image`` exactly.  A scene file's
    image (``fit_image``) gets a render area of its aspect at least :data:`MIN_AREA` high, no
    larger than needed, and the whole window within ``limit`` (the monitor's work area, when
    known): the image is scaled to fit it.
    """
    extra_w = PANEL_WIDTH if panel else 0
    extra_h = STATUS_HEIGHT if status else 0
    w, h = image
    if fit_image:
        scale = max(1.0, MIN_AREA / h)
        if limit is not None:
            scale = min(scale, (limit[0] - extra_w) / w, (limit[1] - extra_h) / h)
        w, h = max(1, round(w * scale)), max(1, round(h * scale))
    return w + extra_w, h + extra_h


def overlaps(a: Rect, b: Rect) -> bool:
    """Whether two rectangles share any area (touching edges do not count)."""
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]


def help_rect(window: tuple[int, int], area: Rect, content: tuple[float, float]) -> Rect:
    """Where the help overlay (F1) goes: ``content`` (its width and height, window pixels) centred on the render
    ``area``, moved and shrunk to lie inside the ``window`` (width, height) :data:`HELP_MARGIN` from its edges
    (less in a tiny window), so that no line starts off the window's left edge; text that does not fit wraps
    or scrolls inside it."""
    win_w, win_h = max(0.0, float(window[0])), max(0.0, float(window[1]))
    margin = min(HELP_MARGIN, win_w / 4, win_h / 4)
    w = max(0.0, min(float(content[0]), win_w - 2 * margin))
    h = max(0.0, min(float(content[1]), win_h - 2 * margin))
    ax, ay, aw, ah = area
    x = min(max(ax + (aw - w) / 2, margin), win_w - margin - w)
    y = min(max(ay + (ah - h) / 2, margin), win_h - margin - h)
    return (x, y, w, h)
