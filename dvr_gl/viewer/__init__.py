"""The interactive viewer behind ``dvr view``: a GLFW window on the same scene model as ``dvr render``.

Pure logic (no window, unit-tested): :mod:`.navigation` (orbit, pan, zoom, projection),
:mod:`.refinement` (progressive refinement against a frame-time budget), :mod:`.tf_editor`
(transfer-function control points), :mod:`.settings` (switching renderer settings), :mod:`.hud`
(frame time, samples per second), :mod:`.keys` (the key bindings) and :mod:`.screenshots`.  The
window side: :mod:`.display` (the image on a quad), :mod:`.imgui_backend` (Dear ImGui from
imgui-bundle, optional, drawn with moderngl), :mod:`.gui` (panels, HUD, help) and :mod:`.app`
(the window and the loop).
"""

__all__ = ["ViewerOptions", "run_viewer"]


def __getattr__(name):
    # The window side (GLFW, imgui-bundle) loads on first use, not with the pure modules.
    if name in __all__:
        from . import app

        return getattr(app, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
