"""Visibility reuse across sweeps: how far the sight lines move, and the blocks that share rays.

The shadow test of a scatterer (is the segment antenna -> scatterer free?) depends only on the
two end points. Over a block of sweeps both ends move a little (the platform by ``v/PRF`` per
sweep, ~2 mm in the paper's set-up), so the sight lines of the block sweep a thin ruled surface
between the block's first and last sight lines. docs/integrator.md §"Visibility reuse" states
the bound this module implements: if both end lines agree, the visibility can differ at an inner
sweep only if an occluder (or a gap between occluders) lies across the surface without touching
either end line, i.e. its section is narrower than the surface's width, which is at most the
*sight-line motion* of the block (:func:`sight_line_motion`). Blocks are therefore cut where
that motion would exceed a given feature width ``w`` (:func:`visibility_blocks`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["shared_probe_sweeps", "sight_line_motion", "visibility_blocks"]


def sight_line_motion(positions: NDArray, times: NDArray, target_speed: float) -> NDArray:
    """Cumulative sight-line motion along a sequence of sweeps [m].

    Implements the width bound of docs/integrator.md §"Visibility reuse": between sweeps ``i``
    and ``j > i`` the sight line of any scatterer moves by at most
    ``c[j] - c[i] = sum |p_{k+1} - p_k| + v_q (t_j - t_i)`` at either end (antenna path length
    plus the largest scatterer displacement), hence at every point in between.

    Parameters
    ----------
    positions : ndarray, shape (n, 3)
        Antenna position at each sweep [m], in sweep order.
    times : ndarray, shape (n,)
        Time of each sweep [s], increasing.
    target_speed : float
        Largest scatterer speed [m/s] (0 for a static scene).

    Returns
    -------
    ndarray, shape (n,)
        ``c``, with ``c[0] = 0`` [m].
    """
    positions = np.asarray(positions, dtype=float)
    times = np.asarray(times, dtype=float)
    step = (np.linalg.norm(np.diff(positions, axis=0), axis=1)
            + abs(float(target_speed)) * np.diff(times))
    return np.concatenate([[0.0], np.cumsum(step)])


def visibility_blocks(motion: NDArray, feature: float, cap: int,
                      shared_ends: bool = False) -> NDArray[np.int64]:
    """Split sweeps into blocks that may share their shadow rays.

    Greedy from the first sweep: a block grows while its sight-line motion ``motion[j] -
    motion[first]`` stays ``<= feature`` and it holds at most ``cap`` sweeps
    (docs/integrator.md §"Visibility reuse"). ``feature = 0`` (or ``cap = 1``) gives one sweep
    per block: a shadow ray per sweep. With ``shared_ends`` a block is probed at its first
    sweep and at the next block's first sweep (:func:`shared_probe_sweeps`), so sweep ``j``
    joins only if ``motion[j + 1] - motion[first] <= feature`` as well (the chunk's last sweep:
    ``motion[j] - motion[first] <= feature``): blocks one sweep shorter, about half the rays.

    Parameters
    ----------
    motion : ndarray, shape (n,)
        Cumulative sight-line motion of the sweeps (:func:`sight_line_motion`) [m].
    feature : float
        Smallest occluder (or gap) width that must be resolved [m], >= 0.
    cap : int
        Largest number of sweeps in a block, >= 1 (e.g. the sweeps between two scene changes).

    Returns
    -------
    ndarray of int, shape (n,)
        Block index of each sweep: 0, 0, ..., 1, 1, ... (non-decreasing, consecutive).
    """
    motion = np.asarray(motion, dtype=float)
    blocks = np.zeros(len(motion), dtype=np.int64)
    block, first = 0, 0
    # A loop over the sweeps of one chunk (<= 128), on the host, once per chunk: not a hot path.
    for i in range(1, len(motion)):
        reach = motion[min(i + 1, len(motion) - 1)] if shared_ends else motion[i]
        if reach - motion[first] > feature or i - first >= cap:
            block, first = block + 1, i
        blocks[i] = block
    return blocks


def shared_probe_sweeps(motion: NDArray, blocks: NDArray, feature: float
                        ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """The sweeps whose shadow rays decide the blocks of ``visibility_blocks(..., shared_ends=
    True)``, each ray shared by two neighbouring blocks.

    Block ``b`` is decided by its first sweep ``f_b`` and by ``f_{b+1}`` (the last block: its
    last sweep): the sight lines of all its sweeps lie between those two, which move by at most
    ``feature`` (the bound of docs/integrator.md §"Visibility reuse"). A one-sweep block whose
    step to the next exceeds ``feature`` is decided by its own sweep alone.

    Returns
    -------
    sweeps : ndarray of int
        Sweeps to probe, increasing (indices into ``motion``).
    first, end : ndarray of int, shape (blocks,)
        For each block, the index into ``sweeps`` of its two deciding sweeps (equal if one).
    """
    motion = np.asarray(motion, dtype=float)
    blocks = np.asarray(blocks, dtype=np.int64)
    count = int(blocks[-1]) + 1
    first = np.searchsorted(blocks, np.arange(count), side="left")
    last = np.searchsorted(blocks, np.arange(count), side="right") - 1
    end = np.append(first[1:], last[-1])
    end = np.where(motion[end] - motion[first] <= feature, end, last)
    sweeps = np.unique(np.concatenate([first, end]))
    return sweeps, np.searchsorted(sweeps, first), np.searchsorted(sweeps, end)
