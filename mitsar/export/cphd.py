"""CPHD 1.0.1 export and import of mitsar raw data (NGA.STND.0068-1, CPHD Design &
Implementation Description Document, Version 1.0.1, 2018), through sarkit.

:func:`write_cphd` writes one monostatic channel in the FX domain: one vector per sweep, the
stop-and-go phase history of :func:`mitsar.export.phase_history.fx_phase_history` (intra-sweep
motion and residual video phase removed, referenced to the SRP, ``SGN = -1``) as ``CF8``. Per
vector (CPHD §4, PVP): ``TxTime = eta_k + T/2`` (mid-sweep), ``RcvTime = TxTime + 2 R_srp / c``,
``TxPos = RcvPos`` the mid-sweep antenna position (the antenna moves < 0.1 µm in the SRP's
delay), ``TxVel = RcvVel``, ``SRPPos`` the scene reference point, ``SC0 = f_c - B/2``,
``SCSS = K / f_s``, ``FX1 = SC0``, ``FX2 = SC0 + (N - 1) SCSS``, ``TOA1/TOA2`` the receive
window ``[0, 2 R_max / c]`` relative to the SRP's delay, ``aFDOP = -2 (dR_srp/dt) / c``,
``aFRR1 = aFRR2 = 0`` (allowed: "may be set equal to zero"), ``TDTropoSRP = 0`` (indoors).
Positions go to ECF through :class:`mitsar.export.frame.LabOrigin`, recorded in
``CollectionID/Parameter`` so :func:`read_cphd` can return to the lab frame. Two added PVPs
(``AddedPVP``) carry the boresight (ECF) and attitude, and ``CollectionID/Parameter`` the
export's steps, the radar and the product's attributes, so that the export can be undone.

:func:`read_cphd` reads a CPHD written here back into the dechirped raw product it was made
from (every step undone, :func:`mitsar.export.phase_history.dechirped_samples`; docs/products.md,
the round trip), which focuses like the original with the same focuser; and any monostatic
FX-domain CPHD with one channel and fixed ``SC0``/``SCSS`` (or ours, ``form="referenced"``)
into a *referenced* raw product (:func:`mitsar.raw.recorded.raw_from_arrays`: reference range
``(|TxPos - SRP| + |RcvPos - SRP|) / 2``), which :func:`mitsar.focus` back-projects
(:mod:`mitsar.focus.referenced`).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import MitsarError, ParameterError
from mitsar.export.frame import DEFAULT_ORIGIN, LabOrigin
from mitsar.export.optional import require_sarkit
from mitsar.export.phase_history import (
    PHASE_SIGN,
    dechirped_samples,
    fx_phase_history,
    scene_reference_point,
)
from mitsar.io import ProductFileError, atomic_writer
from mitsar.model.geometry.attitude import Look
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


def write_cphd(raw_product: xr.Dataset, path: str | os.PathLike, *,
               origin: LabOrigin = DEFAULT_ORIGIN, srp: ArrayLike | None = None,
               image: xr.Dataset | None = None, motion: str = "auto",
               overwrite: bool = False) -> Path:
    """Write a dechirped raw product as an FX-domain CPHD 1.0.1 file (module docstring).

    Parameters
    ----------
    raw_product : xarray.Dataset
        Dechirped raw product (simulated, or recorded with ``continuous_motion=True``).
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
    history = fx_phase_history(raw, point, motion)
    vectors, samples = history.signal.shape

    ecf_position = origin.to_ecf(history.position)
    ecf_velocity = origin.vectors_to_ecf(history.velocity)
    ecf_srp = origin.to_ecf(history.srp)
    srp_range = np.linalg.norm(ecf_position - ecf_srp, axis=1)
    range_rate = np.einsum("si,si->s", ecf_velocity, ecf_position - ecf_srp) / srp_range
    time = history.time - history.time[0] + radar.sweep_duration / 2
    fx1 = history.first_frequency
    fx2 = fx1 + (samples - 1) * history.frequency_step
    toa1 = -2.0 * srp_range / SPEED_OF_LIGHT
    toa2 = toa1 + 2.0 * radar.max_range / SPEED_OF_LIGHT
    words = 0
    layout = {}
    for name, size in (*_PVP_LAYOUT, *((name, 3) for name, _ in _ADDED_PVPS)):
        layout[name] = (words, size)
        words += size
    values = {"TxTime": time, "TxPos": ecf_position, "TxVel": ecf_velocity,
              "RcvTime": time + 2.0 * srp_range / SPEED_OF_LIGHT, "RcvPos": ecf_position,
              "RcvVel": ecf_velocity, "SRPPos": np.broadcast_to(ecf_srp, (vectors, 3)),
              "aFDOP": -2.0 * range_rate / SPEED_OF_LIGHT, "aFRR1": np.zeros(vectors),
              "aFRR2": np.zeros(vectors), "FX1": np.full(vectors, fx1),
              "FX2": np.full(vectors, fx2), "TOA1": toa1, "TOA2": toa2,
              "TDTropoSRP": np.zeros(vectors), "SC0": np.full(vectors, fx1),
              "SCSS": np.full(vectors, history.frequency_step),
              "mitsar_boresight": origin.vectors_to_ecf(np.asarray(raw["boresight"].values,
                                                                   dtype=float)),
              "mitsar_attitude": np.asarray(raw["attitude"].values, dtype=float)}

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
                     "TxTime1": float(time[0]), "TxTime2": float(time[-1])},
        "FxBand": {"FxMin": fx1, "FxMax": fx2},
        "TOASwath": {"TOAMin": float(toa1.min()), "TOAMax": float(toa2.max())}}
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
    corners = origin.to_ecf([history.srp + np.array([x, y, 0.0]) for x, y in polygon])
    xml["SceneCoordinates"]["ImageAreaCornerPoints"] = (
        require_sarkit("sarkit.wgs84").cartesian_to_geodetic(corners)[:, :2])
    xml["Data"] = {
        "SignalArrayFormat": "CF8", "NumBytesPVP": 8 * words, "NumCPHDChannels": 1,
        "Channel": [{"Identifier": "1", "NumVectors": vectors, "NumSamples": samples,
                     "SignalArrayByteOffset": 0, "PVPArrayByteOffset": 0}],
        "NumSupportArrays": 0}
    xml["Channel"] = {
        "RefChId": "1", "FXFixedCPHD": True, "TOAFixedCPHD": False, "SRPFixedCPHD": True,
        "Parameters": [{
            "Identifier": "1", "RefVectorIndex": vectors // 2, "FXFixed": True,
            "TOAFixed": False, "SRPFixed": True,
            "Polarization": {"TxPol": "V", "RcvPol": "V"},
            "FxC": (fx1 + fx2) / 2, "FxBW": fx2 - fx1,
            "TOASaved": float((toa2 - toa1).max()),
            "DwellTimes": {"CODId": "1", "DwellId": "1"}}]}
    pvp = xml["PVP"]
    for name, (offset, size) in layout.items():
        if name.startswith("mitsar_"):
            continue
        pvp[name] = {"Offset": offset, "Size": size, "dtype": np.dtype(
            [("X", "f8"), ("Y", "f8"), ("Z", "f8")] if size == 3 else "f8")}
    pvp["AddedPVP"] = [{"Name": name, "Offset": layout[name][0], "Size": 3,
                        "dtype": np.dtype([(part, "f8") for part in parts])}
                       for name, parts in _ADDED_PVPS]
    # Reference times (CPHD §6.2): tref = TxTime + (RcvTime - TxTime) / 2 (monostatic).
    tref = values["TxTime"] + (values["RcvTime"] - values["TxTime"]) / 2
    xml["Dwell"] = {
        "NumCODTimes": 1,
        "CODTime": [{"Identifier": "1", "CODTimePoly": [[float(tref[0] + tref[-1]) / 2]]}],
        "NumDwellTimes": 1,
        "DwellTime": [{"Identifier": "1", "DwellTimePoly": [[float(tref[-1] - tref[0])]]}]}
    parameters = {**origin.to_parameters(),
                  "mitsar.motion": history.motion, "mitsar.rvp_removed":
                  str(int(history.rvp_removed)), "mitsar.srp_lab": repr(history.srp.tolist()),
                  "mitsar.radar": repr(radar.to_attrs()),
                  "mitsar.motion_azimuth_centre_hz": repr(float(history.azimuth_centre)),
                  "mitsar.slow_time_start": repr(float(raw["slow_time"].values[0])),
                  "mitsar.raw_attrs": json.dumps(_plain_attrs(raw.attrs))}
    collection_node = root.find(f"{{{ns}}}CollectionID")
    for key, value in parameters.items():
        node = etree.SubElement(collection_node, f"{{{ns}}}Parameter", name=key)
        node.text = value
    # CollectionID/Parameter must precede nothing else in CollectionID: it is the last child.
    dtype = skcphd.get_pvp_dtype(etree.ElementTree(root))
    pvp_array = np.zeros(vectors, dtype=dtype)
    for name, value in values.items():
        parts = pvp_array.dtype[name].names  # (H, P, R): structured; (X, Y, Z): (3,) floats
        if parts:
            for i, part in enumerate(parts):
                pvp_array[name][part] = value[:, i]
        else:
            pvp_array[name] = value
    xml["ReferenceGeometry"] = skcphd.compute_reference_geometry(
        etree.ElementTree(root), pvp_array)
    tree = etree.ElementTree(root)
    metadata = skcphd.Metadata(xmltree=tree)
    signal = history.signal.astype(np.complex64)

    def write(tmp: Path) -> None:
        with tmp.open("wb") as handle, skcphd.Writer(handle, metadata) as writer:
            writer.write_signal("1", signal)
            writer.write_pvp("1", pvp_array)

    return atomic_writer(path, overwrite, write)


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
        Channel identifier (default the reference channel).
    form : {"auto", "dechirped", "referenced"}
        ``"dechirped"``: the dechirped raw product the file was written from, every export
        step undone (:func:`mitsar.export.phase_history.dechirped_samples`; needs a file
        written by :func:`write_cphd`, which records the steps, the radar, the product's
        attributes and the boresight and attitude as added PVPs); it focuses like the original
        with every algorithm. ``"referenced"``: the stop-and-go phase history as it is, a
        referenced product (any FX CPHD; back-projection only). ``"auto"``: dechirped when the
        file records mitsar's export, else referenced.

    Returns
    -------
    xarray.Dataset
        Raw product; referenced ones carry ``reference_range`` and ``frequency``.

    Raises
    ------
    ProductFileError
        For a missing or unreadable file, or a CPHD this reader does not handle (not FX,
        varying SC0/SCSS).
    ParameterError
        For an unknown ``form``, or ``"dechirped"`` on a file that does not record mitsar's
        export.
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
            ref = channel or root.findtext("{*}Channel/{*}RefChId")
            signal, pvps = reader.read_channel(ref)
    except (OSError, ValueError, KeyError, TypeError, etree.LxmlError) as error:
        raise ProductFileError(f"{path}: not a readable CPHD file "
                               f"({type(error).__name__}: {error})") from error
    if root.findtext("{*}Global/{*}DomainType") != "FX":
        raise ProductFileError(f"{path}: expected an FX-domain CPHD, found DomainType "
                               f"{root.findtext('{*}Global/{*}DomainType')!r}")
    sc0, scss = np.asarray(pvps["SC0"], float), np.asarray(pvps["SCSS"], float)
    if np.ptp(sc0) > 1e-6 * scss[0] or np.ptp(scss) > 1e-9 * scss[0]:
        raise ProductFileError(f"{path}: SC0/SCSS vary from vector to vector; mitsar needs "
                               "one frequency axis for all vectors")
    parameters = {node.get("name"): node.text
                  for node in root.findall("{*}CollectionID/{*}Parameter")}
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
                  .rsplit("/", 1)[-1], "cphd_channel": ref, "lab_origin": origin.to_parameters()}
    missing = [key for key in _EXPORT_RECORD if key not in parameters] + [
        name for name, _ in _ADDED_PVPS if name not in (pvps.dtype.names or ())]
    if form == "dechirped" and missing:
        raise ParameterError("read_cphd", "form", "'auto' or 'referenced' for a CPHD that "
                             "does not record mitsar's export (not written by "
                             "mitsar.write_cphd)", f"'dechirped' (missing {missing})")
    if form == "dechirped" or (form == "auto" and not missing):
        geometry = SweepGeometry(
            slow_time=np.asarray(pvps["TxTime"], float) - float(pvps["TxTime"][0])
            + float(parameters["mitsar.slow_time_start"]),
            position=position, velocity=velocity,
            boresight=origin.vectors_from_ecf(np.asarray(pvps["mitsar_boresight"], float)),
            attitude=np.column_stack([np.asarray(pvps["mitsar_attitude"][part], float)
                                      for part in ("H", "P", "R")]))
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


def _dechirped_product(path: Path, signal: NDArray, frequencies: NDArray, sign: int,
                       parameters: dict, geometry: SweepGeometry, srp: NDArray,
                       provenance: dict) -> xr.Dataset:
    """The dechirped raw product a mitsar CPHD was written from (``read_cphd(form=...)``)."""
    attrs = json.loads(parameters["mitsar.raw_attrs"])
    radar = Radar.from_attrs(attrs)
    rf = radar.carrier_frequency + radar.chirp_rate * fast_time(radar)
    if len(rf) != len(frequencies) or np.abs(rf - frequencies).max() > 1e-6 * (rf[1] - rf[0]):
        raise ProductFileError(f"{path}: the recorded radar samples {len(rf)} frequencies from "
                               f"{rf[0]:.9g} Hz, the vectors {len(frequencies)} from "
                               f"{frequencies[0]:.9g} Hz; read it with form='referenced'")
    samples = dechirped_samples(
        signal, radar, geometry.position, geometry.velocity, srp,
        parameters["mitsar.motion"], float(parameters["mitsar.motion_azimuth_centre_hz"]),
        parameters["mitsar.rvp_removed"] == "1", sign)
    look = Look(float(attrs.get("look_off_nadir_deg", 0.0)),
                float(attrs.get("look_squint_deg", 0.0)))
    product = make_raw_product(samples, radar, look, geometry,
                               rvp=bool(int(attrs.get("rvp", 1))))
    product.attrs.update(attrs)
    for key, value in provenance.items():
        product.attrs[key] = json.dumps(value) if isinstance(value, dict | list) else value
    return product
