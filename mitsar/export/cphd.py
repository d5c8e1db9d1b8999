"""CPHD 1.0.1 export and import of mitsar raw data (NGA.STND.0068-1, CPHD Design &
Implementation Description Document, Version 1.0.1, 2018), through sarkit.

:func:`write_cphd` writes a monostatic channel in the FX domain: one vector per sweep, the
stop-and-go phase history of :func:`mitsar.export.phase_history.fx_phase_history` (intra-sweep
motion and residual video phase removed, referenced to the SRP, ``SGN = -1``) as ``CF8``. Per
vector (CPHD §4, PVP): ``TxTime = eta_k + T/2`` (mid-sweep), ``RcvTime = TxTime + 2 R_srp / c``,
``TxPos = RcvPos`` the mid-sweep antenna position (the antenna moves < 0.1 µm in the SRP's
delay), ``TxVel = RcvVel``, ``SRPPos`` the scene reference point, ``SC0 = f_c - B/2``,
``SCSS = K / f_s``, ``FX1 = SC0``, ``FX2 = SC0 + (N - 1) SCSS``, ``TOA1/TOA2`` the receive
window ``[0, 2 R_max / c]`` relative to the SRP's delay, ``aFDOP = -2 (dR_srp/dt) / c``,
``aFRR1 = 2 fx_C / (c K)`` and ``aFRR2 = 2 / (c K)`` (CPHD 1.0.1 §4.3, FX domain: the
ratio of the TOA offset to the FX offset of a linear FM of rate ``K``, here the chirp rate),
``TDTropoSRP = 0`` (indoors). ``Channel/Parameters/TOASaved = max(TOA2) - min(TOA1)`` over
the channel's vectors (CPHD 1.0.1 §5.1; TOA1 drifts with the SRP's range over a long
collection, so the per-vector width is not enough), ``SceneCoordinates/ImageGrid`` a
half-cell grid over the ImageArea.
Positions go to ECF through :class:`mitsar.export.frame.LabOrigin`, recorded in
``CollectionID/Parameter`` so :func:`read_cphd` can return to the lab frame. Two added PVPs
(``AddedPVP``) carry the boresight (ECF) and attitude, and ``CollectionID/Parameter`` the
export's steps, the radar and the product's attributes, so that the export can be undone.

A multi-channel raw product (a radar with phase centres: ``channel`` dim,
docs/interferometry.md §8) gives one CPHD channel per channel, ``"CH0"``, ``"CH1"``, ...
(``RefChId`` ``"CH0"``), each with its own vectors and PVPs: ``TxPos``/``RcvPos`` the channel's
transmit and receive phase centres at mid-sweep, track point plus body-frame offset rotated by
the attitude (:func:`mitsar.export.phase_history.phase_centre_tracks`), ``TxVel``/``RcvVel``
the track velocity plus the rotated offset's rate, the SRP compensation and ``RcvTime``,
``TOA1``, ``aFDOP`` on the bistatic delay ``(|TxPos - SRP| + |RcvPos - SRP|) / c``. A
TDM-MIMO channel holds only the vectors of its time slot (the sweeps its transmitter fired),
not every sweep with ``SIGNAL = 0`` elsewhere: a CPHD vector is a transmitted pulse (its
``TxTime``/``TxPos`` would describe a transmission that did not happen), channels may have
different ``NumVectors``, and readers that ignore the optional ``SIGNAL`` PVP would integrate
the silent sweeps (sarkit's checker also warns when fewer than half a channel's vectors have
``SIGNAL = 1``, as they would from three transmitters on). ``CollectType`` stays
``MONOSTATIC`` (one platform; the reference geometry is that of ``CH0``, whose ``ARP`` is the
mid-point of its phase centres); one dwell, the span all channels' vectors cover, serves every
channel. Three more added PVPs, in multi-channel files only, hold the track point and its
velocity (ECF) and the acquisition sweep index (``mitsar_track_position``,
``mitsar_track_velocity``, ``mitsar_sweep``), and ``mitsar.channels`` lists the identifiers
in channel order.
A single-channel product is written as before, byte for byte (one channel ``"1"``).

:func:`read_cphd` reads a CPHD written here back into the dechirped raw product it was made
from (every step undone, :func:`mitsar.export.phase_history.dechirped_samples`; docs/products.md,
the round trip), which focuses like the original with the same focuser (a multi-channel file:
every channel, its phase centres recovered from ``TxPos``/``RcvPos``); and any monostatic
FX-domain CPHD with one channel and fixed ``SC0``/``SCSS`` (or ours, ``form="referenced"``)
into a *referenced* raw product (:func:`mitsar.raw.recorded.raw_from_arrays`: reference range
``(|TxPos - SRP| + |RcvPos - SRP|) / 2``), which :func:`mitsar.focus` back-projects
(:mod:`mitsar.focus.referenced`).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import MitsarError, ParameterError
from mitsar.export.frame import DEFAULT_ORIGIN, LabOrigin
from mitsar.export.optional import require_sarkit
from mitsar.export.phase_history import (
    PHASE_SIGN,
    PhaseHistory,
    dechirped_samples,
    fx_phase_history,
    scene_reference_point,
)
from mitsar.focus.channels import channel_view
from mitsar.io import ProductFileError, atomic_writer
from mitsar.model.geometry.attitude import Look, body_to_world
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import fast_time
from mitsar.products.raw import make_raw_product, radar_of
from mitsar.raw.recorded import raw_from_arrays
from mitsar.version import __version__

__all__ = ["CPHD_NAMESPACE", "read_cphd", "write_cphd"]

CPHD_NAMESPACE = "http://api.nsgreg.nga.mil/schema/cphd/1.0.1"
"""XML namespace of CPHD 1.0.1."""

_PVP_LAYOUT = (("TxTime", 1), ("TxPos", 3), ("TxVel", 3), ("RcvTime", 1), ("RcvPos", 3),
               ("RcvVel", 3), ("SRPPos", 3), ("aFDOP", 1), ("aFRR1", 1), ("aFRR2", 1),
               ("FX1", 1), ("FX2", 1), ("TOA1", 1), ("TOA2", 1), ("TDTropoSRP", 1),
               ("SC0", 1), ("SCSS", 1))
"""The required PVPs of CPHD 1.0.1 (Table 4-1), in file order, with their sizes in words."""

_ADDED_PVPS = (("mitsar_boresight", ("X", "Y", "Z")), ("mitsar_attitude", ("H", "P", "R")))
"""Added PVPs (CPHD §4, ``AddedPVP``) after the required ones, 3 words each: the antenna
boresight (unit vector, ECF) and attitude (heading, pitch, roll [rad], lab frame) at mid-sweep,
which the dechirped raw product holds and the required PVPs do not."""

_CHANNEL_PVPS = (("mitsar_track_position", ("X", "Y", "Z")),
                 ("mitsar_track_velocity", ("X", "Y", "Z")), ("mitsar_sweep", None))
"""Added PVPs of a multi-channel file only, after :data:`_ADDED_PVPS`: the track point (the
body origin whose attitude-rotated offsets give the phase centres) and its velocity at
mid-sweep (ECF, 3 words each), and the vector's acquisition sweep index (``I8``)."""

_EXPORT_RECORD = ("mitsar.raw_attrs", "mitsar.motion", "mitsar.rvp_removed",
                  "mitsar.motion_azimuth_centre_hz", "mitsar.slow_time_start")
"""CollectionID parameters :func:`read_cphd` needs to undo :func:`write_cphd`'s steps."""

FORMS = ("auto", "dechirped", "referenced")
"""What :func:`read_cphd` returns (its docstring)."""

COLLECTION_START = _dt.datetime(2000, 1, 1, tzinfo=_dt.UTC)
"""Collection start written when the product has no absolute time (simulations)."""


def _check_raw(raw: object, where: str) -> xr.Dataset:
    if not isinstance(raw, xr.Dataset) or raw.attrs.get("product") != "raw" \
            or "raw" not in raw.variables:
        found = raw.attrs.get("product") if isinstance(raw, xr.Dataset) else type(raw).__name__
        raise ParameterError(where, "raw_product", "a mitsar raw product (product='raw')",
                             found)
    return raw


def _plain_attrs(attrs: dict) -> dict:
    """The attributes of a product that JSON can hold (NumPy scalars and arrays as Python)."""
    out = {}
    for key, value in attrs.items():
        if isinstance(value, np.ndarray | np.generic):
            value = value.tolist()
        if isinstance(value, str | int | float | bool | list):
            out[key] = value
    return out


@dataclass(frozen=True)
class _ChannelVectors:
    """One CPHD channel of :func:`write_cphd`: its vectors' signal and PVP values (ECF)."""

    identifier: str
    signal: NDArray[np.complex128]
    values: dict[str, NDArray]
    tref: NDArray[np.float64]
    """(vectors,): reference times (CPHD §6.2) [s]."""


def _channel_histories(raw: xr.Dataset, srp: NDArray, motion: str
                       ) -> tuple[list[str], list[xr.Dataset], list[PhaseHistory]]:
    """Identifiers, one-channel views and phase histories of the channels of ``raw``.

    A product without a ``channel`` dim is one channel, ``"1"``; a multi-channel one gives
    ``"CH0"``, ``"CH1"``, ... in channel order, each channel its own phase centres
    (:func:`mitsar.focus.channels.channel_view`: a TDM-MIMO channel keeps only the sweeps its
    transmitter fired). The motion mode and the ``"exact"`` removal's azimuth centre are
    channel 0's, shared by all (one record undoes them all).
    """
    if "channel" not in raw["raw"].dims:
        return ["1"], [raw], [fx_phase_history(raw, srp, motion)]
    views = [channel_view(raw, k) for k in range(raw.sizes["channel"])]
    first = fx_phase_history(views[0], srp, motion)
    histories = [first] + [fx_phase_history(view, srp, first.motion,
                                            azimuth_centre=first.azimuth_centre)
                           for view in views[1:]]
    return [f"CH{k}" for k in range(len(views))], views, histories


def _channel_vectors(identifier: str, view: xr.Dataset, history: PhaseHistory,
                     origin: LabOrigin, ecf_srp: NDArray, start: float, radar: Radar,
                     multi: bool) -> _ChannelVectors:
    """The PVPs of one channel (module docstring): positions and velocities in ECF, times from
    the product's first mid-sweep instant ``start`` [s]."""
    vectors, samples = history.signal.shape
    ecf_position = origin.to_ecf(history.position)
    ecf_velocity = origin.vectors_to_ecf(history.velocity)
    if history.receive_position is None:  # monostatic (or ping-pong): one phase centre
        ecf_receive, ecf_receive_velocity = ecf_position, ecf_velocity
    else:
        ecf_receive = origin.to_ecf(history.receive_position)
        ecf_receive_velocity = origin.vectors_to_ecf(history.receive_velocity)
    transmit_range = np.linalg.norm(ecf_position - ecf_srp, axis=1)
    receive_range = np.linalg.norm(ecf_receive - ecf_srp, axis=1)
    transmit_rate = np.einsum("si,si->s", ecf_velocity, ecf_position - ecf_srp) / transmit_range
    receive_rate = (np.einsum("si,si->s", ecf_receive_velocity, ecf_receive - ecf_srp)
                    / receive_range)
    delay = (transmit_range + receive_range) / SPEED_OF_LIGHT  # 2 R_srp / c when monostatic
    time = history.time - start + radar.sweep_duration / 2
    fx1 = history.first_frequency
    fx2 = fx1 + (samples - 1) * history.frequency_step
    toa1 = -delay
    toa2 = toa1 + 2.0 * radar.max_range / SPEED_OF_LIGHT
    values = {"TxTime": time, "TxPos": ecf_position, "TxVel": ecf_velocity,
              "RcvTime": time + delay, "RcvPos": ecf_receive,
              "RcvVel": ecf_receive_velocity, "SRPPos": np.broadcast_to(ecf_srp, (vectors, 3)),
              "aFDOP": -2.0 * ((transmit_rate + receive_rate) / 2.0) / SPEED_OF_LIGHT,
              "aFRR1": np.full(vectors, (fx1 + fx2) / (SPEED_OF_LIGHT * radar.chirp_rate)),
              "aFRR2": np.full(vectors, 2.0 / (SPEED_OF_LIGHT * radar.chirp_rate)),
              "FX1": np.full(vectors, fx1),
              "FX2": np.full(vectors, fx2), "TOA1": toa1, "TOA2": toa2,
              "TDTropoSRP": np.zeros(vectors), "SC0": np.full(vectors, fx1),
              "SCSS": np.full(vectors, history.frequency_step),
              "mitsar_boresight": origin.vectors_to_ecf(np.asarray(view["boresight"].values,
                                                                   dtype=float)),
              "mitsar_attitude": np.asarray(view["attitude"].values, dtype=float)}
    if multi:
        values.update(
            mitsar_track_position=origin.to_ecf(np.asarray(view["platform_position"].values,
                                                           dtype=float)),
            mitsar_track_velocity=origin.vectors_to_ecf(
                np.asarray(view["platform_velocity"].values, dtype=float)),
            mitsar_sweep=np.asarray(view["sweep"].values, dtype=np.int64))
    # Reference times (CPHD §6.2): tref = TxTime + r_xmt / (r_xmt + r_rcv) (RcvTime - TxTime),
    # the midpoint when monostatic.
    share = transmit_range / (transmit_range + receive_range)
    tref = values["TxTime"] + (values["RcvTime"] - values["TxTime"]) * share
    return _ChannelVectors(identifier, history.signal, values, tref)


def _pvp_layout(multi: bool) -> tuple[dict[str, tuple[int, int]], tuple, int]:
    """Word offset and size of every PVP, the added PVPs (name, parts or None for one
    integer word), and the words per vector."""
    added = (*_ADDED_PVPS, *(_CHANNEL_PVPS if multi else ()))
    words = 0
    layout = {}
    for name, parts in (*((name, ("X", "Y", "Z")[:size] if size == 3 else None)
                          for name, size in _PVP_LAYOUT), *added):
        size = 1 if parts is None else len(parts)
        layout[name] = (words, size)
        words += size
    return layout, added, words


def write_cphd(raw_product: xr.Dataset, path: str | os.PathLike, *,
               origin: LabOrigin = DEFAULT_ORIGIN, srp: ArrayLike | None = None,
               image: xr.Dataset | None = None, motion: str = "auto",
               overwrite: bool = False) -> Path:
    """Write a dechirped raw product as an FX-domain CPHD 1.0.1 file (module docstring).

    Parameters
    ----------
    raw_product : xarray.Dataset
        Dechirped raw product (simulated, or recorded with ``continuous_motion=True``); with a
        ``channel`` dim (a radar with phase centres), one CPHD channel per channel.
    path : path-like
        Output file (conventionally ``*.cphd``), written atomically.
    origin : LabOrigin
        Where the lab frame sits on the Earth.
    srp : array_like, shape (3,), optional
        Scene reference point in the lab frame [m]; default the centre pixel of ``image`` or
        where the mid-sweep boresight meets z = 0 (:func:`scene_reference_point`).
    image : xarray.Dataset, optional
        An image product of the same data, whose centre pixel is the default SRP.
    motion : {"auto", "exact", "srp", "none"}
        Intra-sweep motion removal (:mod:`mitsar.export.phase_history`).
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ParameterError
        For a product that is not a dechirped raw product or bad options.
    OutputExistsError
        If ``path`` exists and ``overwrite`` is false.
    MitsarError
        If sarkit is not installed (``pip install mitsar[nga]``).
    """
    raw = _check_raw(raw_product, "write_cphd")
    if not isinstance(origin, LabOrigin):
        raise ParameterError("write_cphd", "origin", "a LabOrigin", type(origin).__name__)
    skcphd = require_sarkit("sarkit.cphd")
    etree = require_sarkit("lxml.etree")
    radar = radar_of(raw)
    point = scene_reference_point(raw, image) if srp is None else srp
    identifiers, views, histories = _channel_histories(raw, point, motion)
    multi = "channel" in raw["raw"].dims
    history = histories[0]
    samples = history.signal.shape[1]
    ecf_srp = origin.to_ecf(history.srp)
    # the product's first mid-sweep instant: TxTime counts from T/2 in every channel
    start = (np.asarray(raw["slow_time"].values, dtype=float) + radar.sweep_duration / 2)[0]
    channels = [_channel_vectors(identifier, view, channel_history, origin, ecf_srp, start,
                                 radar, multi)
                for identifier, view, channel_history in zip(identifiers, views, histories,
                                                             strict=True)]
    fx1 = history.first_frequency
    fx2 = fx1 + (samples - 1) * history.frequency_step
    layout, added, words = _pvp_layout(multi)
    tx_first = min(channel.values["TxTime"][0] for channel in channels)
    tx_last = max(channel.values["TxTime"][-1] for channel in channels)

    ns = CPHD_NAMESPACE
    root = etree.Element(f"{{{ns}}}CPHD", nsmap={None: ns})
    xml = skcphd.ElementWrapper(root)
    collection = {
        "CollectorName": "mitsar FMCW SAR", "CoreName": f"mitsar-{__version__}",
        "CollectType": "MONOSTATIC", "RadarMode": {"ModeType": "STRIPMAP"},
        "Classification": "UNCLASSIFIED", "ReleaseInfo": "UNRESTRICTED"}
    xml["CollectionID"] = collection
    xml["Global"] = {
        "DomainType": "FX", "SGN": PHASE_SIGN,
        "Timeline": {"CollectionStart": COLLECTION_START,
                     "TxTime1": float(tx_first), "TxTime2": float(tx_last)},
        "FxBand": {"FxMin": fx1, "FxMax": fx2},
        "TOASwath": {"TOAMin": float(min(c.values["TOA1"].min() for c in channels)),
                     "TOAMax": float(max(c.values["TOA2"].max() for c in channels))}}
    half_extent = max(float(radar.max_range), 1.0)
    up = origin.rotation[:, 2]
    u_x = origin.rotation[:, 0]
    llh = require_sarkit("sarkit.wgs84").cartesian_to_geodetic(ecf_srp)
    polygon = [(-half_extent, -half_extent), (-half_extent, half_extent),
               (half_extent, half_extent), (half_extent, -half_extent)]
    xml["SceneCoordinates"] = {
        "EarthModel": "WGS_84",
        "IARP": {"ECF": ecf_srp, "LLH": llh},
        "ReferenceSurface": {"Planar": {"uIAX": u_x, "uIAY": np.cross(up, u_x)}},
        "ImageArea": {"X1Y1": [-half_extent, -half_extent],
                      "X2Y2": [half_extent, half_extent]}}
    area = xml["SceneCoordinates"]["ImageArea"]
    area["Polygon"] = np.array(polygon)
    # ImageGrid (CPHD 1.0.1 §6.2): half-cell sampling of the range resolution c / (2 B) over
    # the ImageArea, IARP at the grid's centre, so the grid's extent is the ImageArea's.
    grid_spacing = SPEED_OF_LIGHT / (4.0 * radar.bandwidth)
    grid_lines = int(math.ceil(2.0 * half_extent / grid_spacing))
    xml["SceneCoordinates"]["ImageGrid"] = {
        "Identifier": "mitsar",
        "IARPLocation": [grid_lines / 2 - 0.5, grid_lines / 2 - 0.5],
        "IAXExtent": {"LineSpacing": grid_spacing, "FirstLine": 0, "NumLines": grid_lines},
        "IAYExtent": {"SampleSpacing": grid_spacing, "FirstSample": 0,
                      "NumSamples": grid_lines}}
    corners = origin.to_ecf([history.srp + np.array([x, y, 0.0]) for x, y in polygon])
    xml["SceneCoordinates"]["ImageAreaCornerPoints"] = (
        require_sarkit("sarkit.wgs84").cartesian_to_geodetic(corners)[:, :2])
    data_channels, signal_offset, pvp_offset = [], 0, 0
    for channel in channels:
        vectors = len(channel.signal)
        data_channels.append({"Identifier": channel.identifier, "NumVectors": vectors,
                              "NumSamples": samples, "SignalArrayByteOffset": signal_offset,
                              "PVPArrayByteOffset": pvp_offset})
        signal_offset += vectors * samples * np.dtype(np.complex64).itemsize
        pvp_offset += vectors * 8 * words
    xml["Data"] = {
        "SignalArrayFormat": "CF8", "NumBytesPVP": 8 * words,
        "NumCPHDChannels": len(channels), "Channel": data_channels, "NumSupportArrays": 0}
    xml["Channel"] = {
        "RefChId": identifiers[0], "FXFixedCPHD": True, "TOAFixedCPHD": False,
        "SRPFixedCPHD": True,
        "Parameters": [{
            "Identifier": channel.identifier, "RefVectorIndex": len(channel.signal) // 2,
            "FXFixed": True, "TOAFixed": False, "SRPFixed": True,
            "Polarization": {"TxPol": "V", "RcvPol": "V"},
            "FxC": (fx1 + fx2) / 2, "FxBW": fx2 - fx1,
            "TOASaved": float(channel.values["TOA2"].max() - channel.values["TOA1"].min()),
            "DwellTimes": {"CODId": "1", "DwellId": "1"}} for channel in channels]}
    pvp = xml["PVP"]
    for name, (offset, size) in layout.items():
        if name.startswith("mitsar_"):
            continue
        pvp[name] = {"Offset": offset, "Size": size, "dtype": np.dtype(
            [("X", "f8"), ("Y", "f8"), ("Z", "f8")] if size == 3 else "f8")}
    pvp["AddedPVP"] = [{"Name": name, "Offset": layout[name][0], "Size": layout[name][1],
                        "dtype": np.dtype("i8") if parts is None
                        else np.dtype([(part, "f8") for part in parts])}
                       for name, parts in added]
    # One dwell for all channels: the span every channel's vectors support (the dwell must lie
    # within each channel's reference times; TDM-MIMO slots are offset by 1/PRF)
    tref_first = max(channel.tref[0] for channel in channels)
    tref_last = min(channel.tref[-1] for channel in channels)
    xml["Dwell"] = {
        "NumCODTimes": 1,
        "CODTime": [{"Identifier": "1", "CODTimePoly": [[float(tref_first + tref_last) / 2]]}],
        "NumDwellTimes": 1,
        "DwellTime": [{"Identifier": "1",
                       "DwellTimePoly": [[float(tref_last - tref_first)]]}]}
    parameters = {**origin.to_parameters(),
                  "mitsar.motion": history.motion, "mitsar.rvp_removed":
                  str(int(history.rvp_removed)), "mitsar.srp_lab": repr(history.srp.tolist()),
                  "mitsar.radar": repr(radar.to_attrs()),
                  "mitsar.motion_azimuth_centre_hz": repr(float(history.azimuth_centre)),
                  "mitsar.slow_time_start": repr(float(raw["slow_time"].values[0])),
                  "mitsar.raw_attrs": json.dumps(_plain_attrs(raw.attrs))}
    if multi:
        parameters["mitsar.channels"] = json.dumps(identifiers)
    collection_node = root.find(f"{{{ns}}}CollectionID")
    for key, value in parameters.items():
        node = etree.SubElement(collection_node, f"{{{ns}}}Parameter", name=key)
        node.text = value
    # CollectionID/Parameter must precede nothing else in CollectionID: it is the last child.
    dtype = skcphd.get_pvp_dtype(etree.ElementTree(root))
    pvp_arrays = [_pvp_array(channel.values, dtype) for channel in channels]
    xml["ReferenceGeometry"] = skcphd.compute_reference_geometry(
        etree.ElementTree(root), pvp_arrays[0])
    tree = etree.ElementTree(root)
    metadata = skcphd.Metadata(xmltree=tree)

    def write(tmp: Path) -> None:
        with tmp.open("wb") as handle, skcphd.Writer(handle, metadata) as writer:
            for channel, pvp_array in zip(channels, pvp_arrays, strict=True):
                writer.write_signal(channel.identifier, channel.signal.astype(np.complex64))
                writer.write_pvp(channel.identifier, pvp_array)

    return atomic_writer(path, overwrite, write)


def _pvp_array(values: dict[str, NDArray], dtype: np.dtype) -> NDArray:
    """The PVP array of one channel from its values (:func:`_channel_vectors`)."""
    pvp_array = np.zeros(len(values["TxTime"]), dtype=dtype)
    for name, value in values.items():
        parts = pvp_array.dtype[name].names  # (H, P, R): structured; (X, Y, Z): (3,) floats
        if parts:
            for i, part in enumerate(parts):
                pvp_array[name][part] = value[:, i]
        else:
            pvp_array[name] = value
    return pvp_array


def read_cphd(path: str | os.PathLike, *, origin: LabOrigin | None = None,
              channel: str | None = None, form: str = "auto") -> xr.Dataset:
    """Read an FX-domain CPHD into a mitsar raw product (module docstring).

    Parameters
    ----------
    path : path-like
        CPHD file (1.0.1 or 1.1.0).
    origin : LabOrigin, optional
        Lab frame to return positions in; default the one recorded by :func:`write_cphd`,
        else a local east-north-up frame at the scene's IARP.
    channel : str, optional
        Channel identifier. Default: every channel of a multi-channel file written by
        :func:`write_cphd` (dechirped form), else the reference channel. Given, that channel
        alone (of a multi-channel mitsar file: :func:`mitsar.focus.channels.channel_view` of
        the product read back).
    form : {"auto", "dechirped", "referenced"}
        ``"dechirped"``: the dechirped raw product the file was written from, every export
        step undone (:func:`mitsar.export.phase_history.dechirped_samples`; needs a file
        written by :func:`write_cphd`, which records the steps, the radar, the product's
        attributes and the boresight and attitude as added PVPs); it focuses like the original
        with every algorithm. A multi-channel file gives back the multi-channel product
        (``channel`` dim), its phase centres recovered from the PVPs. ``"referenced"``: the
        stop-and-go phase history of one channel as it is, a referenced product (any FX CPHD;
        back-projection only). ``"auto"``: dechirped when the file records mitsar's export,
        else referenced.

    Returns
    -------
    xarray.Dataset
        Raw product; referenced ones carry ``reference_range`` and ``frequency``.

    Raises
    ------
    ProductFileError
        For a missing or unreadable file, or a CPHD this reader does not handle (not FX,
        varying SC0/SCSS), or a multi-channel file whose PVPs disagree with its record.
    ParameterError
        For an unknown ``form`` or ``channel``, or ``"dechirped"`` on a file that does not
        record mitsar's export.
    """
    if form not in FORMS:
        raise ParameterError("read_cphd", "form", f"one of {FORMS}", form)
    skcphd = require_sarkit("sarkit.cphd")
    etree = require_sarkit("lxml.etree")
    path = Path(path)
    if not path.is_file():
        raise ProductFileError(f"{path}: no such file")
    try:
        with path.open("rb") as handle, skcphd.Reader(handle) as reader:
            tree = reader.metadata.xmltree
            root = tree.getroot()
            identifiers = [node.findtext("{*}Identifier")
                           for node in root.findall("{*}Data/{*}Channel")]
            if channel is not None and channel not in identifiers:
                raise ParameterError("read_cphd", "channel", f"one of {identifiers}", channel)
            parameters = {node.get("name"): node.text
                          for node in root.findall("{*}CollectionID/{*}Parameter")}
            ordered = (json.loads(parameters["mitsar.channels"])
                       if "mitsar.channels" in parameters and form != "referenced" else None)
            ref = channel or root.findtext("{*}Channel/{*}RefChId")
            wanted = ordered if ordered is not None else [ref]
            channels = {identifier: reader.read_channel(identifier) for identifier in wanted}
    except ParameterError:
        raise
    except (OSError, ValueError, KeyError, TypeError, etree.LxmlError) as error:
        raise ProductFileError(f"{path}: not a readable CPHD file "
                               f"({type(error).__name__}: {error})") from error
    if root.findtext("{*}Global/{*}DomainType") != "FX":
        raise ProductFileError(f"{path}: expected an FX-domain CPHD, found DomainType "
                               f"{root.findtext('{*}Global/{*}DomainType')!r}")
    signal, pvps = channels[wanted[0]]
    sc0 = np.concatenate([np.asarray(p["SC0"], float) for _, p in channels.values()])
    scss = np.concatenate([np.asarray(p["SCSS"], float) for _, p in channels.values()])
    if np.ptp(sc0) > 1e-6 * scss[0] or np.ptp(scss) > 1e-9 * scss[0]:
        raise ProductFileError(f"{path}: SC0/SCSS vary from vector to vector; mitsar needs "
                               "one frequency axis for all vectors")
    if origin is None:
        origin = LabOrigin.from_parameters(parameters)
    if origin is None:
        llh = [float(root.findtext(f"{{*}}SceneCoordinates/{{*}}IARP/{{*}}LLH/{{*}}{k}"))
               for k in ("Lat", "Lon", "HAE")]
        origin = LabOrigin(*llh, azimuth_deg_of_x=90.0)
    tx, rcv = np.asarray(pvps["TxPos"], float), np.asarray(pvps["RcvPos"], float)
    srp = np.asarray(pvps["SRPPos"], float)
    reference = (np.linalg.norm(tx - srp, axis=1) + np.linalg.norm(rcv - srp, axis=1)) / 2
    position = origin.from_ecf((tx + rcv) / 2)
    velocity = origin.vectors_from_ecf((np.asarray(pvps["TxVel"], float)
                                        + np.asarray(pvps["RcvVel"], float)) / 2)
    lab_srp = origin.from_ecf(srp)
    frequencies = sc0[0] + scss[0] * np.arange(signal.shape[1])
    sign = int(float(root.findtext("{*}Global/{*}SGN")))
    provenance = {"source": str(path), "source_format": "CPHD " + root.nsmap[None]
                  .rsplit("/", 1)[-1], "cphd_channel": ref if ordered is None else ordered,
                  "lab_origin": origin.to_parameters()}
    needed = [name for name, _ in (*_ADDED_PVPS, *(_CHANNEL_PVPS if ordered else ()))]
    missing = [key for key in _EXPORT_RECORD if key not in parameters] + [
        name for name in needed if name not in (pvps.dtype.names or ())]
    if form == "dechirped" and missing:
        raise ParameterError("read_cphd", "form", "'auto' or 'referenced' for a CPHD that "
                             "does not record mitsar's export (not written by "
                             "mitsar.write_cphd)", f"'dechirped' (missing {missing})")
    if ordered is not None and not missing:
        product = _dechirped_channels(path, [channels[i] for i in ordered], frequencies,
                                      sign, parameters, origin, lab_srp[0], provenance)
        return product if channel is None else channel_view(product, ordered.index(channel))
    if form == "dechirped" or (form == "auto" and not missing):
        geometry = SweepGeometry(
            slow_time=np.asarray(pvps["TxTime"], float) - float(pvps["TxTime"][0])
            + float(parameters["mitsar.slow_time_start"]),
            position=position, velocity=velocity,
            boresight=origin.vectors_from_ecf(np.asarray(pvps["mitsar_boresight"], float)),
            attitude=_attitude(pvps))
        return _dechirped_product(path, signal, frequencies, sign, parameters, geometry,
                                  lab_srp[0], provenance)  # SRPFixed: one SRP
    try:
        product = raw_from_arrays(
            signal, frequencies, position, sweep_times=np.asarray(pvps["TxTime"], float),
            phase_sign=sign, reference_range=reference, velocities=velocity,
            boresight=lab_srp - position, attrs=provenance)
    except ParameterError as error:
        raise MitsarError(f"{path}: cannot read as a mitsar raw product: {error}") from error
    return product


def _attitude(pvps: NDArray) -> NDArray:
    """(vectors, 3) heading, pitch, roll [rad] from the added PVP ``mitsar_attitude``."""
    return np.column_stack([np.asarray(pvps["mitsar_attitude"][part], float)
                            for part in ("H", "P", "R")])


def _recorded_radar(path: Path, parameters: dict, frequencies: NDArray
                    ) -> tuple[dict, Radar]:
    """The raw product's attributes and radar recorded by :func:`write_cphd`, checked against
    the vectors' frequencies."""
    attrs = json.loads(parameters["mitsar.raw_attrs"])
    radar = Radar.from_attrs(attrs)
    rf = radar.carrier_frequency + radar.chirp_rate * fast_time(radar)
    if len(rf) != len(frequencies) or np.abs(rf - frequencies).max() > 1e-6 * (rf[1] - rf[0]):
        raise ProductFileError(f"{path}: the recorded radar samples {len(rf)} frequencies from "
                               f"{rf[0]:.9g} Hz, the vectors {len(frequencies)} from "
                               f"{frequencies[0]:.9g} Hz; read it with form='referenced'")
    return attrs, radar


def _finish(product: xr.Dataset, attrs: dict, provenance: dict) -> xr.Dataset:
    """The recorded attributes and the provenance on a product read back."""
    product.attrs.update(attrs)
    for key, value in provenance.items():
        product.attrs[key] = json.dumps(value) if isinstance(value, dict | list) else value
    return product


def _look(attrs: dict) -> Look:
    """The antenna look recorded in a product's attributes."""
    return Look(float(attrs.get("look_off_nadir_deg", 0.0)),
                float(attrs.get("look_squint_deg", 0.0)))


def _dechirped_product(path: Path, signal: NDArray, frequencies: NDArray, sign: int,
                       parameters: dict, geometry: SweepGeometry, srp: NDArray,
                       provenance: dict) -> xr.Dataset:
    """The dechirped raw product a mitsar CPHD was written from (``read_cphd(form=...)``)."""
    attrs, radar = _recorded_radar(path, parameters, frequencies)
    samples = dechirped_samples(
        signal, radar, geometry.position, geometry.velocity, srp,
        parameters["mitsar.motion"], float(parameters["mitsar.motion_azimuth_centre_hz"]),
        parameters["mitsar.rvp_removed"] == "1", sign)
    product = make_raw_product(samples, radar, _look(attrs), geometry,
                               rvp=bool(int(attrs.get("rvp", 1))))
    return _finish(product, attrs, provenance)


PHASE_CENTRE_TOLERANCE = 1e-6
"""Largest disagreement [m] between a phase centre recovered from a multi-channel file's PVPs
and the body-frame offset its recorded radar declares (ECF round trips cost ~1e-9 m)."""


def _dechirped_channels(path: Path, channels: list[tuple[NDArray, NDArray]],
                        frequencies: NDArray, sign: int, parameters: dict, origin: LabOrigin,
                        srp: NDArray, provenance: dict) -> xr.Dataset:
    """The multi-channel dechirped raw product a mitsar CPHD was written from.

    The sweeps are the union of the channels' ``mitsar_sweep`` (a TDM-MIMO channel holds its
    slot's only; its other sweeps are zeros, as simulated), the track comes from the added
    PVPs ``mitsar_track_position``/``_velocity``, and each channel is undone on its own
    ``TxPos``/``RcvPos``/``TxVel``/``RcvVel`` (:func:`dechirped_samples`). The body-frame
    phase centres are recovered from the PVPs, ``R(attitude)^T (TxPos - track)`` (and the
    same for ``RcvPos``), and must agree with the recorded radar's within
    :data:`PHASE_CENTRE_TOLERANCE` in every vector.
    """
    attrs, radar = _recorded_radar(path, parameters, frequencies)
    sweep_sets = [np.asarray(pvps["mitsar_sweep"], dtype=np.int64) for _, pvps in channels]
    sweeps = np.unique(np.concatenate(sweep_sets))
    first_time = min(float(pvps["TxTime"][0]) for _, pvps in channels)
    start = float(parameters["mitsar.slow_time_start"])
    slow_time = np.empty(len(sweeps))
    track = {name: np.empty((len(sweeps), 3)) for name in ("position", "velocity",
                                                            "boresight", "attitude")}
    samples = np.zeros((len(channels), len(sweeps), len(frequencies)), dtype=np.complex128)
    held = np.zeros((len(channels), len(sweeps)), dtype=bool)
    transmitters, receivers = radar.channel_offsets()
    residual = 0.0
    for k, (signal, pvps) in enumerate(channels):
        rows = np.searchsorted(sweeps, sweep_sets[k])
        held[k, rows] = True
        slow_time[rows] = np.asarray(pvps["TxTime"], float) - first_time + start
        position = origin.from_ecf(np.asarray(pvps["mitsar_track_position"], float))
        attitude = _attitude(pvps)
        track["position"][rows] = position
        track["velocity"][rows] = origin.vectors_from_ecf(
            np.asarray(pvps["mitsar_track_velocity"], float))
        track["boresight"][rows] = origin.vectors_from_ecf(
            np.asarray(pvps["mitsar_boresight"], float))
        track["attitude"][rows] = attitude
        ecf_tx, ecf_rcv = np.asarray(pvps["TxPos"], float), np.asarray(pvps["RcvPos"], float)
        transmit = origin.from_ecf(ecf_tx)
        receive = None if np.array_equal(ecf_tx, ecf_rcv) else origin.from_ecf(ecf_rcv)
        rotation = body_to_world(*attitude.T)
        for found, expected in ((transmit, transmitters[k]),
                                (transmit if receive is None else receive, receivers[k])):
            body = np.einsum("sji,sj->si", rotation, found - position)
            residual = max(residual, float(np.abs(body - np.asarray(expected)).max()))
        samples[k, rows] = dechirped_samples(
            signal, radar, transmit, origin.vectors_from_ecf(np.asarray(pvps["TxVel"], float)),
            srp, parameters["mitsar.motion"],
            float(parameters["mitsar.motion_azimuth_centre_hz"]),
            parameters["mitsar.rvp_removed"] == "1", sign, receive_positions=receive,
            receive_velocities=None if receive is None else origin.vectors_from_ecf(
                np.asarray(pvps["RcvVel"], float)),
            sweep_rate=radar.prf / radar.transmitter_count)
    if residual > PHASE_CENTRE_TOLERANCE:
        raise ProductFileError(f"{path}: the channels' TxPos/RcvPos put the phase centres "
                               f"{residual:.3g} m from the recorded radar's body-frame offsets "
                               f"(tolerance {PHASE_CENTRE_TOLERANCE:g} m)")
    if not np.array_equal(held, radar.firing(sweeps)):
        raise ProductFileError(f"{path}: the channels' vectors are not the sweeps their "
                               "transmitters fire (Radar.firing)")
    geometry = SweepGeometry(slow_time=slow_time, **track)
    product = make_raw_product(samples, radar, _look(attrs), geometry,
                               rvp=bool(int(attrs.get("rvp", 1))), sweeps=sweeps)
    provenance = {**provenance, "cphd_phase_centre_residual_m": residual}
    return _finish(product, attrs, provenance)
