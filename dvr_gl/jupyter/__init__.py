"""The interactive notebook widget: :func:`widget` (also ``dvr_gl.widget``) shows a scene in Jupyter, rendered
on the kernel's side (EGL or OSMesa, offscreen) and sent to the browser as pictures through
``jupyter_rfb``'s remote frame buffer, so it works on a remote server (JupyterHub, a cluster node) as well as
locally, in JupyterLab, Notebook and VS Code.  See docs/widget.md.

The parts: :mod:`.looks` (a field's transfer function from a preset, window/level and an opacity scale; pure),
:mod:`.canvas` (the frame buffer: pointer and wheel events to the camera, progressive refinement, the frames),
:mod:`.controls` (the ipywidgets panel beside it), :mod:`.tf_canvas` (the panel's drawn transfer-function editor,
the viewer's editor model on a second, small frame buffer).  jupyter_rfb and ipywidgets are the optional extra
``widget``, imported only when a widget is made.
"""

from __future__ import annotations

from ..errors import DvrError, install_hint


def widget(data, *, time_axis: int | None = None, budget: float = 0.1, **render_options):
    """An interactive view of ``data`` (what :func:`dvr_gl.render` takes: an array ``[z, y, x]``, a field, a
    file, a :class:`~dvr_gl.Scene`; or a :class:`~dvr_gl.fields.series.TimeSeries`) with the ``render_options``
    of :func:`dvr_gl.render` (``size``, ``transfer_function``, ``renderer``, settings, the camera).

    ``time_axis``: the axis of time steps of a 4D array (a time slider).  ``budget``: seconds a frame may
    take while dragging (coarser frames hold it).  ``max_pixel_ratio``: the most physical pixels per CSS pixel
    the image is rendered at on a HiDPI screen (default 2; 1: CSS pixels, four times cheaper).  Returns a
    :class:`~dvr_gl.jupyter.canvas.VolumeWidget`:
    shown as the last expression of a cell (the picture with its controls); ``.scene`` the current scene,
    ``.snapshot()`` the full-quality :class:`~dvr_gl.Image`; ``.pick(x, y)`` what lies under widget pixel
    ``(x, y)``; ``.annotated()`` the annotated 8-bit picture; ``.camera_path`` the recorded keyframes."""
    try:
        import ipywidgets  # noqa: F401
        import jupyter_rfb  # noqa: F401
    except ImportError as exc:
        raise DvrError(f"dvr_gl.widget needs jupyter_rfb and ipywidgets ({exc.name} is missing): "
                       f"{install_hint('widget')}") from None
    from .canvas import VolumeWidget

    return VolumeWidget.of(data, time_axis=time_axis, budget=budget, **render_options)
