"""Focusing a multi-channel raw product: every channel by back-projection onto one grid.

A radar with declared phase centres (:attr:`mitsar.model.radar.Radar.has_channels`) makes raw
products with a ``channel`` dimension. Each channel is focused on its own exact geometry (its
transmitter and receiver at the track point plus their body-frame offsets rotated by the
attitude: :func:`mitsar.focus.bp_setup.channel_phase_centres`, the delay of the exact path
``(|t - x| + |x - r|) / c``) onto the *same pixels*: the grid is resolved once, on channel 0,
and the other channels are back-projected onto its pixel positions. So the channel images are
co-registered by construction, and a scatterer exactly at a pixel has the same phase in every
channel: the phase of the reference surface (the grid) is removed per pixel from the exact
geometry (docs/interferometry.md).

The image product gains ``channel`` in front of the grid's dims, the channels' body-frame
``transmitter_offset`` / ``receiver_offset`` (channel, xyz) [m] and the processed aperture's
track (``aperture_position`` (aperture, xyz) [m], ``aperture_attitude`` (aperture, angle)
[rad], ``aperture_time`` (aperture) [s], at mid-sweep), which the interferometry stage reads.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import xarray as xr

from mitsar.errors import ParameterError
from mitsar.focus.autofocus.apply import correct_raw
from mitsar.focus.grid import Grid, PointsGrid, VolumeGrid
from mitsar.products.raw import radar_of

__all__ = ["CHANNEL_ALGORITHMS", "channel_view", "focus_channels"]

CHANNEL_ALGORITHMS = ("bpa",)
"""Algorithms that focus multi-channel products: back-projection takes each channel's exact
bistatic path; FFBP's polar stages and the spectral algorithms assume a monostatic antenna."""

_OFFSETS = ("transmitter_offset", "receiver_offset")


def channel_view(raw: xr.Dataset, channel: int) -> xr.Dataset:
    """One channel of a multi-channel raw product as a single-channel raw product.

    Its ``raw`` is (sweep, sample); it keeps the channel's body-frame ``transmitter_offset``
    and ``receiver_offset`` (xyz) [m], which back-projection places on the track
    (:func:`mitsar.focus.bp_setup.channel_phase_centres`), and the attribute ``channel``.

    A TDM-MIMO channel (a product with ``fires``: :func:`mitsar.products.raw.channel_variables`)
    keeps only the sweeps its transmitter fired, every N_tx-th, each with its own track point
    (the per-slot motion), and the attribute ``sweep_stride = N_tx``: the focusers then sample
    the aperture at ``prf / N_tx`` (:func:`mitsar.products.raw.sweep_rate`), so their sweep
    windows and full-aperture weights count only the channel's sweeps.
    """
    view = raw.isel(channel=channel)
    attrs = {**raw.attrs, "channel": int(channel)}
    if "fires" in raw.variables:
        fires = np.asarray(view["fires"].values, dtype=bool)
        indices = np.asarray(raw["sweep"].values)[fires]
        stride = radar_of(raw).transmitter_count
        if len(indices) > 1 and not np.all(np.diff(indices) == stride):
            raise ParameterError("channel_view", "raw.sweep", f"the channel's sweeps every "
                                 f"{stride}-th (TDM-MIMO with {stride} transmitters: a contiguous "
                                 "run of acquisition sweeps)", "a gap in the sweeps")
        view = view.isel(sweep=np.flatnonzero(fires)).drop_vars(
            ["fires", "channel_transmitter", "channel_receiver"], errors="ignore")
        attrs["sweep_stride"] = int(stride)
    view.attrs = attrs
    return view


def focus_channels(raw: xr.Dataset, algorithm: str, grid: Grid,
                   focus_one: Callable[[xr.Dataset, Grid, str | None], xr.Dataset],
                   autofocus: str | None = None) -> xr.Dataset:
    """Focus every channel of ``raw`` onto the pixels of channel 0's grid (module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        A raw product with a ``channel`` dimension.
    algorithm : str
        Must be one of :data:`CHANNEL_ALGORITHMS`.
    grid : Grid
        The output grid, resolved on channel 0.
    focus_one : callable
        ``focus_one(single_channel_raw, grid, autofocus) -> image``: :func:`mitsar.focus` with
        the caller's options.
    autofocus : {"pga", "entropy"} or None
        Autofocus channel 0 and apply *its* phase per sweep to every channel
        (:func:`mitsar.focus.autofocus.apply.correct_raw`) before focusing them: the error of
        a navigation track is the platform's, common to phase centres centimetres apart, and
        one phase screen keeps the interferometric phase unbiased (an autofocus per channel
        would give each channel its own constant and linear phase). The image records
        ``autofocus_phase`` and ``autofocus_channels = "channel 0's phase applied to all"``.
        Not with TDM-MIMO (its channels hold different sweeps).

    Returns
    -------
    xarray.Dataset
        The image product with a ``channel`` dimension (module docstring).
    """
    if algorithm not in CHANNEL_ALGORITHMS:
        raise ParameterError("focus", "algorithm", f"one of {CHANNEL_ALGORITHMS} for a "
                             f"multi-channel raw product ({raw.sizes['channel']} channels: each "
                             "channel's exact bistatic path is back-projected); or focus one "
                             "channel: mitsar.focus.channels.channel_view(raw, k)", algorithm)
    if autofocus is not None and radar_of(raw).is_tdm:
        raise ParameterError("focus", "autofocus", "None for a TDM-MIMO raw product (its "
                             "channels hold the sweeps of different transmitters; "
                             "docs/interferometry.md)", autofocus)
    first = focus_one(channel_view(raw, 0), grid, autofocus)
    # a volume's voxels are in the scene frame already (the same for every channel)
    pixels = grid if isinstance(grid, VolumeGrid) else PointsGrid(first["position"].values)

    def view(k: int) -> xr.Dataset:
        if autofocus is None:
            return channel_view(raw, k)
        return correct_raw(channel_view(raw, k), first["autofocus_phase"].values)

    images = [first["image"].values] + [focus_one(view(k), pixels, None)["image"].values
                                        for k in range(1, raw.sizes["channel"])]
    image = first.copy()
    image["image"] = (("channel", *first["image"].dims), np.stack(images),
                      first["image"].attrs)
    image = image.assign_coords(channel=raw["channel"].values)
    for name in _OFFSETS:
        image[name] = raw[name]
    for name in ("channel_transmitter", "channel_receiver"):  # TDM-MIMO: the channel's pair
        if name in raw.variables:
            image[name] = raw[name]
    radar = radar_of(raw)
    image["aperture_position"] = (("aperture", "xyz"), raw["platform_position"].values,
                                  {"units": "m", "long_name": "track point at mid-sweep"})
    image["aperture_attitude"] = (("aperture", "angle"), raw["attitude"].values,
                                  {"units": "rad", "long_name": "heading, pitch, roll"})
    image["aperture_time"] = (("aperture",), raw["slow_time"].values
                              + radar.sweep_duration / 2, {"units": "s",
                                                           "long_name": "mid-sweep time"})
    image.attrs.pop("channel", None)
    if autofocus is not None:
        image.attrs["autofocus_channels"] = "channel 0's phase applied to all"
    return image
