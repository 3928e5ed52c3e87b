"""A least-recently-used cache of arrays bounded in bytes (the host-memory side of out-of-core reading)."""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np


class ByteLRU:
    """At most ``capacity`` bytes of arrays (their ``nbytes``), the least recently used evicted first.

    An array larger than the whole capacity is not kept.  Safe to share between threads (a Dask
    worker's).  ``hits`` and ``misses`` count :meth:`get`'s answers; ``evicted`` the arrays dropped.
    """

    def __init__(self, capacity: int):
        self.capacity = max(0, int(capacity))
        self._items: OrderedDict = OrderedDict()
        self.nbytes = 0
        self.hits = self.misses = self.evicted = 0
        self._lock = threading.Lock()

    def get(self, key):
        """The array kept under ``key`` (now the most recently used), or None."""
        with self._lock:
            value = self._items.get(key)
            if value is None:
                self.misses += 1
                return None
            self._items.move_to_end(key)
            self.hits += 1
            return value

    def put(self, key, value: np.ndarray):
        """Keep ``value`` under ``key``, evicting the least recently used until it fits."""
        size = int(value.nbytes)
        with self._lock:
            old = self._items.pop(key, None)
            if old is not None:
                self.nbytes -= int(old.nbytes)
            if size > self.capacity:
                return
            while self._items and self.nbytes + size > self.capacity:
                _, dropped = self._items.popitem(last=False)
                self.nbytes -= int(dropped.nbytes)
                self.evicted += 1
            self._items[key] = value
            self.nbytes += size

    def clear(self):
        with self._lock:
            self._items.clear()
            self.nbytes = 0

    def __len__(self) -> int:
        return len(self._items)

    def __contains__(self, key) -> bool:
        return key in self._items

    def __repr__(self) -> str:
        return (f"ByteLRU({len(self)} arrays, {self.nbytes} of {self.capacity} bytes, {self.hits} hits, "
                f"{self.misses} misses)")
