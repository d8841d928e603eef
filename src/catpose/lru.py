"""A small bounded least-recently-used cache, the one cache policy of catpose.

Every in-memory cache (partial-template dictionaries, per-template descriptors and target
clouds, ICP's downsampled templates) is an :class:`LRUCache`: a lookup refreshes an entry, and
inserting beyond ``maxsize`` evicts the entry used longest ago. Entries are rebuilt on a miss,
so eviction only costs time, never changes a result.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class LRUCache(Generic[K, V]):
    """Bounded mapping with least-recently-used eviction.

    Args:
        maxsize: the most entries kept (>= 1).
    """

    def __init__(self, maxsize: int) -> None:
        if int(maxsize) < 1:
            raise ValueError(f"LRUCache maxsize={maxsize} must be >= 1")
        self.maxsize = int(maxsize)
        self._data: OrderedDict[K, V] = OrderedDict()

    def get(self, key: K) -> V | None:
        """The value of ``key`` (now the most recently used), or None when absent."""
        if key not in self._data:
            return None
        self._data.move_to_end(key)
        return self._data[key]

    def put(self, key: K, value: V) -> None:
        """Store ``value`` as the most recently used entry; evict the oldest beyond ``maxsize``."""
        self._data[key] = value
        self._data.move_to_end(key)
        while len(self._data) > self.maxsize:
            self._data.popitem(last=False)

    def get_or_build(self, key: K, build: Callable[[], V]) -> V:
        """The cached value of ``key``, or ``build()`` stored under it."""
        hit = self.get(key)
        if hit is None:
            hit = build()
            self.put(key, hit)
        return hit

    def clear(self) -> None:
        self._data.clear()
