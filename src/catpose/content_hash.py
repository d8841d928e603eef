"""Content hashes of arrays and templates, the keys of every cache.

Template ids alone can repeat across datasets (synthetic ids do not name the seed), so caches
key on the content: blake2b over the float64 bytes of the arrays, then any parameter text.
"""

from __future__ import annotations

import hashlib
import re
import weakref

import numpy as np


def content_hash(*arrays: np.ndarray, extra: str = "", digest_size: int = 8) -> str:
    """Hex blake2b digest of ``arrays`` (each as contiguous float64 bytes, in order) and ``extra``."""
    h = hashlib.blake2b(digest_size=digest_size)
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    if extra:
        h.update(extra.encode())
    return h.hexdigest()


_TEMPLATES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def template_hash(template, *fields: str, extra: str = "", digest_size: int = 8) -> str:
    """:func:`content_hash` of a template's arrays ``fields`` (names: ``"points"``, ``"vertices"``,
    ...), once per template object (a template's arrays are not changed in place; an object no weak
    reference can name is hashed every time)."""
    try:
        memo = _TEMPLATES.setdefault(template, {})
    except TypeError:
        memo = {}
    key = (fields, extra, digest_size)
    if key not in memo:
        memo[key] = content_hash(*(getattr(template, f) for f in fields), extra=extra, digest_size=digest_size)
    return memo[key]


def template_key(template, digest_size: int = 8) -> str:
    """``<safe template id>-<hash of its points and normals>`` for a :class:`~catpose.types.Template`."""
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", template.template_id)[-80:]
    return f"{safe}-{template_hash(template, 'points', 'normals', digest_size=digest_size)}"
