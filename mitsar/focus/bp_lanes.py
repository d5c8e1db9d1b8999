"""How the pixel-group back-projection cuts its pixels into lanes and how many share a lookup.

The host-side planning of :mod:`mitsar.focus.bp_tiled` (its module docstring, steps 1 and 5,
has the derivations): lanes of G neighbouring pixels along a grid's rows (or columns) with a
float64 centre each (:func:`lanes_of`, the expansion's error bound, :data:`PHASE_LIMIT`),
the regular-row test (:func:`row_step`), whether every lookup stays inside the profile
(:func:`lookups_inside`), and how many neighbours may share one cubic packet
(:func:`shared_slots`, :func:`column_order`). NumPy only; the kernel is in
:mod:`mitsar.focus.bp_tiled`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from mitsar.focus.aperture import median_sweep_interval
from mitsar.focus.backprojection import SMALLEST_WINDOW_STEP
from mitsar.model.geometry.bounds import bounding_box
from mitsar.model.radar import SPEED_OF_LIGHT, Radar

__all__ = ["LANE_SIZES", "PHASE_LIMIT", "SHARED_SLOTS", "column_order", "lane_layout",
           "lanes_of", "lookups_inside", "nearest_range", "row_step", "shared_slots",
           "slab_transpose"]

LANE_SIZES = (32, 16, 8, 4)
"""Pixels per lane tried, largest first (more pixels share a lane's float64 work)."""

PHASE_LIMIT = 1e-4
"""Largest phase error [rad] that the range expansion (eq. 1 of :mod:`mitsar.focus.bp_tiled`)
may leave at any pixel and sweep."""


def lane_layout(count: int, row_length: int | None, size: int) -> NDArray[np.int64]:
    """Pixel indices of every lane, shape (L, size), -1 for padding.

    Pixels are in row-major order with rows of ``row_length`` pixels (a grid's fastest axis;
    None: one row of all the pixels); each row is cut into lanes of ``size`` consecutive
    pixels, the last one padded, so that no lane straddles two rows.
    """
    row = count if not row_length else int(row_length)
    rows = -(-count // row) if count else 0
    per_row = -(-row // size)
    index = np.full((rows, per_row * size), -1, dtype=np.int64)
    flat = np.arange(rows * row).reshape(rows, row)
    index[:, :row] = np.where(flat < count, flat, -1)
    return index.reshape(-1, size)


def row_step(pixels: NDArray, row_length: int | None, tolerance: float = 1e-9
             ) -> NDArray[np.float64] | None:
    """The common step vector [m] between neighbours along the rows, or None.

    Defined when the pixels form whole rows of ``row_length`` points each spaced by one and
    the same vector (within ``tolerance`` metres): the regular grids (plane, slant, volume
    slices with uniform axes). The lanes then hold ``x = c + m A`` with literal offsets m.
    """
    if not row_length or row_length < 2 or len(pixels) % row_length:
        return None
    rows = pixels.reshape(-1, row_length, 3)
    step = rows[0, 1] - rows[0, 0]
    steps = np.subtract(rows[:, 1:], rows[:, :-1])   # one temporary, reused in place
    steps -= step
    np.abs(steps, out=steps)
    return None if steps.max() > tolerance else step


def _nearest_range(centre: NDArray, positions: NDArray) -> NDArray:
    """A lower bound [m] of the distance from every lane centre to the track: the distance to
    64 samples of the track less half the longest path between two samples."""
    samples = np.unique(np.linspace(0, len(positions) - 1, 64).round().astype(int))
    path = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(positions, axis=0),
                                                           axis=-1))])
    slack = 0.5 * float(np.max(np.diff(path[samples]), initial=0.0))
    track = positions[samples]
    distance = np.sqrt(np.maximum((centre ** 2).sum(-1)[:, None] - 2 * centre @ track.T
                                  + (track ** 2).sum(-1)[None], 0.0)).min(axis=1)
    return distance - slack


def lanes_of(pixels: NDArray, row_length: int | None, size: int, step: NDArray | None,
           positions: NDArray, limit: float, receivers: NDArray | None = None
           ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Lane indices (L, G), centres (L, 3), pixel offsets (L, G, 3) and the predicted range
    error ``h^4 / (2 r^3)`` [m] of every lane (inf where ``r < 4 h``), eq. (1) of
    :mod:`mitsar.focus.bp_tiled`.

    With a row ``step`` the centre is the middle of the lane's G slots, so that slot g sits at
    ``c + (g - (G - 1) / 2) A`` (a padded slot past the row's end too, discarded later);
    otherwise it is the mean of the lane's pixels. ``limit`` [m]: where one bound for all the
    lanes stays below it, that bound is returned for every lane. ``receivers``: a bistatic
    channel's receive phase centres (S, 3), a track of their own: ``r`` is then the nearer of
    the two tracks' (step 6 of :mod:`mitsar.focus.bp_tiled`).
    """
    groups = lane_layout(len(pixels), row_length, size)
    if step is not None:
        slot = np.arange(size) - (size - 1) / 2
        centre = pixels[groups[:, 0]] - slot[0] * step  # the first slot is always a pixel
        offsets = np.broadcast_to(slot[:, None] * step, (len(groups), size, 3))
        reach = np.full(len(groups), np.abs(slot).max() * np.linalg.norm(step))
    else:
        valid = groups >= 0
        points = pixels[np.where(valid, groups, 0)]                     # (L, G, 3)
        weights = valid[..., None].astype(float)
        centre = (points * weights).sum(axis=1) / np.maximum(weights.sum(axis=1), 1.0)
        offsets = np.where(valid[..., None], points - centre[:, None], 0.0)
        reach = np.sqrt((offsets ** 2).sum(axis=-1)).max(axis=1)
    # one bound for all the lanes first (the nearest point of their bounding box to the
    # track), per lane only if that one fails
    widest = float(reach.max(initial=0.0))
    low, high = bounding_box(centre)
    low, high = low - widest, high + widest
    tracks = [positions] if receivers is None else [positions, receivers]
    r = min(nearest_range(track, low, high) for track in tracks) - widest
    if r > 4 * widest and widest ** 4 / (2 * r ** 3) <= limit:
        return groups, centre, offsets, np.full(len(groups), widest ** 4 / (2 * r ** 3))
    # any pixel-to-antenna distance exceeds it (each track on its own: _nearest_range's slack
    # is half the longest step between its samples)
    r = np.min([_nearest_range(centre, track) for track in tracks], axis=0) - reach
    error = np.where(r > 4 * reach, reach ** 4 / (2 * np.maximum(r, 1e-9) ** 3), np.inf)
    return groups, centre, offsets, error


def lookups_inside(frequency: NDArray, radar: Radar, centres: NDArray, positions: NDArray,
                    velocities: NDArray, reach: float) -> bool:
    """Whether every lookup of every lane slot (within ``reach`` metres of its lane's centre)
    from every sweep falls inside the profile axis, so the kernel may skip its bounds test:
    ranges from the slots' bounding box to the track, plus the largest Doppler shift
    ``f_c v / K`` in range, one bin of margin."""
    low_corner, high_corner = bounding_box(centres)
    low_corner, high_corner = low_corner - reach, high_corner + reach
    nearest = np.linalg.norm(positions - np.clip(positions, low_corner, high_corner),
                             axis=-1).min()
    corners = np.array(np.meshgrid(*zip(low_corner, high_corner, strict=True),
                                   indexing="ij")).reshape(3, -1).T
    farthest = np.linalg.norm(positions[:, None] - corners[None], axis=-1).max()
    shift = radar.carrier_frequency * float(np.linalg.norm(velocities, axis=-1).max()) \
        / radar.chirp_rate
    step = frequency[1] - frequency[0]
    first = (radar.beat_frequency(max(nearest - shift, 0.0)) - frequency[0]) / step
    last = (radar.beat_frequency(farthest + shift) - frequency[0]) / step
    return bool(first >= 1 and last <= len(frequency) - 3)


SHARED_SLOTS = (16, 8, 4, 2)
"""Pixels per shared lookup tried, largest first (step 5 of :mod:`mitsar.focus.bp_tiled`)."""


def shared_slots(step: NDArray, size: int, frequency: NDArray, radar: Radar, nearest: float,
                 reach: float, positions: NDArray, velocities: NDArray,
                 centroid_sine: NDArray, half_width: float, fractional: bool,
                 baseline: float = 0.0) -> int:
    """Pixels of a regular row that may share one lookup (step 5 of
    :mod:`mitsar.focus.bp_tiled`): the largest S of
    :data:`SHARED_SLOTS` dividing the lane size with ``(S - 1) sigma <= 1`` (every slot's
    lookup position within half a bin of the group middle's), else 1.

    ``sigma`` bounds the change of the lookup position from one slot to the next [bins] in a
    group of S slots of which one at least is in the window. The range changes along the row
    step ``A`` at the rate ``|A| A^.u`` (u the unit line of sight), and ``|A^.u| <= |a|
    |v^.u| + sqrt(1 - a^2)`` with ``a = A^.v^`` (v^ the sweep's direction of motion); a slot in
    the window has ``|v^.u - u_c| <= h'``, ``h' = h`` plus, with edge fractions, half the
    largest step of window offset from one sweep to the next (``|v| T / R``, floored as
    :func:`mitsar.focus.backprojection.inverse_window_step` floors it), and its group's
    other slots are within ``(S - 1) |A| / R`` of its direction sine (``R = nearest - 2
    reach``: ``nearest`` [m] bounds the range from the pixels to the track below, and every
    slot, padding past a row's end included, lies within ``reach`` of its lane centre, itself
    within ``reach`` of a pixel); so ``c = max_k
    min(1, |a_k| (|u_c,k| + h' + (S - 1) |A| / R) + sqrt(1 - a_k^2))``. The direction sine
    changes by at most ``2 |A| / R`` per slot, which moves the Doppler term. A bistatic
    channel (receiver at most ``baseline`` [m] from the transmitter, ``nearest`` the nearer
    of the two phase centres') looks up half its path, whose change per slot is the mean of
    the two legs'; its receiver's line of sight is within ``baseline / R`` of the
    transmitter's, which widens the spread by that much. Hence ``sigma =
    |A| (b c + 2 d / R)`` with ``b`` bins per metre of range and ``d`` the largest Doppler
    shift in bins (``f_c |v| / K`` in range), and 1 % of margin for the float32 polynomials of
    eqs. (1)-(2) of :mod:`mitsar.focus.bp_tiled`. Along the track ``c`` is about the
    window's largest direction sine (0.16 for the paper radar's whole beam), across it 1.
    ``c`` depends on the track and the window only, ``R`` (in the small terms) on
    ``nearest``: a focus by pixel chunks passes the whole grid's, so that every chunk shares
    alike.
    """
    df = float(frequency[1] - frequency[0])
    per_metre = 2 * radar.chirp_rate / (SPEED_OF_LIGHT * df)
    speed = np.linalg.norm(velocities, axis=-1)
    doppler = 2 * radar.carrier_frequency / (SPEED_OF_LIGHT * df) * float(speed.max(initial=0))
    nearest = nearest - 2 * reach   # R: any slot's range
    length = float(np.linalg.norm(step))
    if nearest <= 0 or length == 0 or not (speed > 0).all():
        return 1
    along = np.abs(velocities @ (step / length)) / speed       # |A^.v^| per sweep
    across = np.sqrt(np.maximum(1 - along**2, 0.0))
    window = half_width
    if fractional:  # edge fractions reach half a sweep's step of window offset past h
        window += 0.5 * max(float(speed.max()) * median_sweep_interval(positions, velocities)
                            / nearest, SMALLEST_WINDOW_STEP)
    for slots in SHARED_SLOTS:
        if size % slots:
            continue
        spread = ((slots - 1) * length + baseline) / nearest
        cosine = min(1.0, float((along * (np.abs(centroid_sine) + window + spread)
                                 + across).max()))
        sigma = 1.01 * length * (per_metre * cosine + 2 * doppler / nearest)
        if (slots - 1) * sigma <= 1:
            return slots
    return 1


def column_order(pixels: NDArray, row_length: int | None, slab_rows: int | None,
                 velocities: NDArray, centroid_sine: NDArray, half_width: float
                 ) -> NDArray[np.int64] | None:
    """The pixel order that lays the lanes along the columns of each slab, or None (rows).

    ``pixels`` in row-major order, rows of ``row_length``, ``slab_rows`` rows per slab (a
    volume's z slices; None: one slab). Columns where a column step moves the lookup less
    per pixel: ``|A| c(A)`` smaller than for the row step by a quarter at least, ``c`` the
    bound of ``|Â.û|`` of :func:`shared_slots` without its range-dependent spread, so the
    choice depends on the grid's first row and column steps, the track and the window only
    (a volume and its slices, and every pixel chunk, choose alike). A row across the track
    moves the lookup by up to a pixel's size in range per pixel, a column along it by that
    times the window's direction sine. Whether the columns are regular is left to the
    caller (:func:`mitsar.focus.bp_tiled.backproject_tiled` tests the lanes it lays).
    """
    if not row_length or row_length < 2 or len(pixels) % row_length:
        return None
    rows = len(pixels) // row_length
    slab_rows = slab_rows or rows
    speed = np.linalg.norm(velocities, axis=-1)
    if rows % slab_rows or slab_rows < LANE_SIZES[0] or not (speed > 0).all():
        return None

    def change(along: NDArray) -> float:  # |A| c(A), per metre of range per pixel
        length = float(np.linalg.norm(along))
        if length == 0:
            return math.inf
        a = np.abs(velocities @ (along / length)) / speed
        cosine = a * (np.abs(centroid_sine) + half_width) + np.sqrt(np.maximum(1 - a**2, 0.0))
        return length * min(1.0, float(cosine.max()))

    row, column = pixels[1] - pixels[0], pixels[row_length] - pixels[0]
    if change(column) >= 0.75 * change(row):
        return None
    return slab_transpose(len(pixels), row_length, slab_rows)


def slab_transpose(count: int, row_length: int, slab_rows: int) -> NDArray[np.int64]:
    """The row-major order of ``count`` pixels read column by column within each slab of
    ``slab_rows`` rows of ``row_length``: slab by slab, each column's pixels consecutive."""
    return (np.arange(count).reshape(-1, slab_rows, row_length).transpose(0, 2, 1).ravel())


def nearest_range(positions: NDArray, low: NDArray, high: NDArray) -> float:
    """The smallest distance [m] from the antenna ``positions`` (S, 3) to the box [low, high]."""
    return float(np.linalg.norm(positions - np.clip(positions, low, high), axis=-1).min())
