"""The scene contract: what a scene is, below every renderer.

- :mod:`.model`: the vocabulary (compositing modes, filters, classifications, ...);
- :mod:`.settings`: every setting a scene key or flag can carry (:class:`~.settings.Setting`), its checks;
- :mod:`.sweeps`: the trade-off families a renderer declares;
- :mod:`.schema`: the scene file's tables and keys as typed specs;
- :mod:`.resolve`: a scene file or overrides to a resolved :class:`~.resolve.Scene` (``load_scene``);
- :mod:`.reference`: the generated reference of every key (``docs/scene-files.md``).

The renderers (:mod:`dvr_gl.renderers`) build on it; nothing here imports a renderer.  Import what you need
from its module (``from dvr_gl.scene.resolve import load_scene``); ``dvr_gl.load_scene`` and
``dvr_gl.Scene`` are the public names.
"""
