"""The texture budget's least-recently-used cache of brick textures: the bricks of a volume read out
of core, and those drawn from its coarser levels, are read and uploaded only when missing
(:meth:`dvr_gl.renderers.grid.sampling.GridRenderer.view_textures`)."""

from __future__ import annotations

from collections import OrderedDict

from ...gl.frame import release_entry


class TextureLRU:
    """Brick textures, least recently used first out, within ``budget`` bytes (the most recent entry
    stays even alone over it: a pass needs its brick); ``uploaded``: bytes uploaded so far, ``hits``
    and ``misses`` of :meth:`get`."""

    def __init__(self, budget: int = 0):
        self.budget, self.used, self.uploaded, self.hits, self.misses = budget, 0, 0, 0, 0
        self._entries: "OrderedDict[tuple, tuple[dict, int, tuple]]" = OrderedDict()

    def get(self, key: tuple, make, alive=()) -> dict:
        """The textures under ``key``, or ``make() -> (textures, bytes)`` made and kept; ``alive``: the
        objects whose ``id`` the key holds, referenced by the entry so that no other object takes an
        id while it is cached."""
        entry = self._entries.pop(key, None)
        if entry is None:
            self.misses += 1
            self._evict_for(0)
            textures, size = make()
            entry = (textures, size, alive)
            self.uploaded += size
            self.used += size
        else:
            self.hits += 1
        self._entries[key] = entry
        self._evict_for(0, keep=key)
        return entry[0]

    def _evict_for(self, nbytes: int, keep=None):
        while self._entries and self.used + nbytes > self.budget:
            key = next(iter(self._entries))
            if key == keep:
                break
            textures, size, _ = self._entries.pop(key)
            for tex in textures.values():
                release_entry(tex)
            self.used -= size

    def release(self):
        self.budget = 0
        self._evict_for(0)
        self._entries.clear()
        self.used = 0
