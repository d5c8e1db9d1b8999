"""Geometry a focus derives from the track and the pixels alone, computed once within a scope.

Autofocus focuses the same raw product twice (:mod:`mitsar.focus.autofocus.driver`): once as
recorded, to choose scatterers, and once with its sweeps multiplied by ``exp(-j phi_k)``. The
corrected product has the same track and the same pixels, so whatever the focuser derives from
those alone (on curved tracks the per-pixel aspect frames,
:func:`mitsar.focus.aperture.aspect_frames`, and the per-pixel sweep ranges,
:func:`mitsar.focus.bpa.curved_sweep_range`) is the same both times. Within
:func:`shared_geometry`, :func:`reuse` computes such a value once per content of its inputs and
hands the same arrays back on the second call; outside it, :func:`reuse` just computes.

The key is a digest of the inputs' bytes, shapes and types (BLAKE2b, RFC 7693), not their
identity: a second focus that builds equal arrays anew finds them, and different geometry
never collides. Measured on the traced room of ``docs/autofocus.md`` (300 sweeps, 240 x 100
pixels): the two functions were 95 % of a focus; the digest of the pixels takes ~1 ms.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, TypeVar

import numpy as np

__all__ = ["geometry_shared", "reuse", "shared_geometry"]

T = TypeVar("T")

_STORE: ContextVar[dict | None] = ContextVar("mitsar_focus_shared_geometry", default=None)


@contextmanager
def shared_geometry() -> Iterator[None]:
    """Within the block, :func:`reuse` computes each value once per content of its inputs (the
    values are dropped when the block ends)."""
    token = _STORE.set({})
    try:
        yield
    finally:
        _STORE.reset(token)


def geometry_shared() -> bool:
    """Whether a :func:`shared_geometry` block is active."""
    return _STORE.get() is not None


def reuse(name: str, inputs: tuple, compute: Callable[[], T]) -> T:
    """``compute()``, or the value it gave before in this :func:`shared_geometry` block for
    inputs of the same content under the same ``name``.

    Parameters
    ----------
    name : str
        What is computed (part of the key).
    inputs : tuple
        Everything ``compute`` depends on: arrays, numbers, None, or tuples of them.
    compute : callable
        Computes the value; its result must not be modified by the caller (it is shared).
    """
    store = _STORE.get()
    if store is None:
        return compute()
    key = (name, _digest(inputs))
    if key not in store:
        store[key] = compute()
    return store[key]


def _digest(value: Any) -> bytes:
    """BLAKE2b digest of arrays (type, shape, bytes), numbers, None and tuples of them."""
    digest = hashlib.blake2b(digest_size=32)

    def feed(item: Any) -> None:
        if item is None:
            digest.update(b"N")
        elif isinstance(item, tuple | list):
            digest.update(b"(%d" % len(item))
            for part in item:
                feed(part)
            digest.update(b")")
        else:
            array = np.ascontiguousarray(item)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())

    feed(value)
    return digest.digest()
