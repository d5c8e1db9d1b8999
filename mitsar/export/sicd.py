"""SICD 1.4.0 export of mitsar images (NGA.STND.0024-1, Sensor Independent Complex Data,
Volume 1 Design & Implementation Description Document, Version 1.4.0, 2024), through sarkit.

What is written (the mapping; details in docs/products.md)
----------------------------------------------------------
* Pixels: the complex ``image`` as ``RE32F_IM32F`` (complex64), with SICD rows along the
  image's range-like dimension (the one ``range_axis`` points along) and columns along the
  other; rows run away from the radar and columns so that ``uRow x uCol`` points up
  (SICD's "shadows down", normal away from the Earth), which for mitsar's left-looking slant
  grid reverses the along-track axis. :func:`sicd_pixels` returns exactly the written array.
* Grid (``Type = PLANE``; every mitsar 2-D grid is a uniform planar grid): ``UVectECF`` from
  the pixel positions, ``SS`` the pixel spacing, ``ImpRespBW = 1 / rho`` from the image's
  ``range_resolution`` / ``azimuth_resolution`` (one cell ``c/2B`` and ``rho``),
  ``ImpRespWid`` the -3 dB width of the window's response (0.8859 rho for "rect", SICD's
  KAPFAC), ``Sgn = -1`` and ``KCtr = (2 f_c / c) (l . u)`` with ``l`` the line of sight at the
  centre of aperture: back-projection leaves the carrier ``exp(-j 2 pi (2 f_c / c) l . x)`` in
  the pixels (docs/conventions.md, BPA de-rotation), which is SICD's spatial-frequency model
  with ``Sgn = -1`` and that ``KCtr``. ``DeltaK1/2 = -+ ImpRespBW / 2``.
* ImageFormation: ``ImageFormAlgo`` "RMA" for RDA/WDA/FSA, "OTHER" for BPA/FFBP (attribute
  ``algorithm``), processed band and time from the raw product.
* Geometry: ``Position/ARPPoly`` a polynomial fit (order <= 5) of the mid-sweep antenna
  positions against time, ``GeoData/SCP`` the centre pixel, corner points, ``SCPCOA`` computed
  by sarkit (``compute_scp_coa``), all in ECF through :class:`mitsar.export.frame.LabOrigin`,
  recorded with the radar parameters in ``CollectionInfo/Parameter``.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from mitsar.errors import ParameterError
from mitsar.export.frame import DEFAULT_ORIGIN, LabOrigin
from mitsar.export.optional import require_sarkit
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.io import atomic_writer
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.version import __version__

__all__ = ["SICD_NAMESPACE", "impulse_width_factor", "sicd_layout", "sicd_pixels", "write_sicd"]

SICD_NAMESPACE = "urn:SICD:1.4.0"
"""XML namespace of SICD 1.4.0."""

ALGORITHMS = {"rda": "RMA", "wda": "RMA", "fsa": "RMA", "bpa": "OTHER", "ffbp": "OTHER"}
"""SICD ``ImageFormAlgo`` of each mitsar algorithm."""

WINDOW_NAMES = {"rect": "UNIFORM", "hamming": "HAMMING", "hann": "HANNING", "taylor": "TAYLOR"}
"""SICD ``WgtType/WindowName`` of each mitsar window."""

COLLECT_START = _dt.datetime(2000, 1, 1, tzinfo=_dt.UTC)
"""Collection start written for simulations (no absolute time)."""


def impulse_width_factor(window: str) -> float:
    """-3 dB width of a window's impulse response in cells (1/bandwidth): 0.8859 for "rect"
    (SICD's KAPFAC), from a 64x zero-padded FFT of the window (Cumming & Wong 2005 §2.6)."""
    if window == "rect":
        return 0.8859
    samples = 256
    weights = evaluate_window(window_coefficients(window), (np.arange(samples) + 0.5) / samples)
    response = np.abs(np.fft.fftshift(np.fft.fft(weights, n=64 * samples)))
    response /= response.max()
    above = np.flatnonzero(response >= math.sqrt(0.5))
    return float((above[-1] - above[0] + 1) / 64)


def _check_image(image: object) -> xr.Dataset:
    if not isinstance(image, xr.Dataset) or image.attrs.get("product") != "image" \
            or "image" not in image.variables:
        found = image.attrs.get("product") if isinstance(image, xr.Dataset) \
            else type(image).__name__
        raise ParameterError("write_sicd", "image_product",
                             "a mitsar image product (product='image')", found)
    if image["image"].ndim != 2 or image.attrs.get("grid_kind") not in ("slant", "plane"):
        raise ParameterError("write_sicd", "image_product",
                             "a 2-D image on a slant or plane grid (metre coordinates)",
                             image.attrs.get("grid_kind"))
    for dim in image["image"].dims:
        step = np.diff(np.asarray(image[dim].values, dtype=float))
        if len(step) < 1 or np.ptp(step) > 1e-9 * abs(step[0]):
            raise ParameterError("write_sicd", f"image_product.{dim}",
                                 "uniformly spaced coordinates [m]", "non-uniform spacing")
    return image


def sicd_layout(image_product: xr.Dataset, arp: np.ndarray | None = None) -> dict:
    """How an image maps onto SICD rows and columns (module docstring).

    Returns
    -------
    dict
        ``row_dim``, ``col_dim`` (image dims), ``flip_row``, ``flip_col`` (reversed),
        ``u_row``, ``u_col`` (lab unit vectors), ``row_spacing``, ``col_spacing`` [m].
    """
    image = _check_image(image_product)
    dims = image["image"].dims
    axis = np.abs(np.asarray(image.attrs.get("range_axis", [0.0, 1.0]), dtype=float))
    row_index = int(np.argmax(axis))
    row_dim, col_dim = dims[row_index], dims[1 - row_index]
    position = image["position"].transpose(row_dim, col_dim, "xyz").values
    u_row = position[1, 0] - position[0, 0]
    u_col = position[0, 1] - position[0, 0]
    row_spacing, col_spacing = float(np.linalg.norm(u_row)), float(np.linalg.norm(u_col))
    u_row, u_col = u_row / row_spacing, u_col / col_spacing
    centre = position[position.shape[0] // 2, position.shape[1] // 2]
    flip_row = arp is not None and float(u_row @ (centre - arp)) < 0
    if flip_row:
        u_row = -u_row
    flip_col = float(np.cross(u_row, u_col)[2]) < 0
    if flip_col:
        u_col = -u_col
    return {"row_dim": row_dim, "col_dim": col_dim, "flip_row": bool(flip_row),
            "flip_col": bool(flip_col), "u_row": u_row, "u_col": u_col,
            "row_spacing": row_spacing, "col_spacing": col_spacing}


def sicd_pixels(image_product: xr.Dataset, layout: dict | None = None) -> np.ndarray:
    """The (rows, cols) complex64 array :func:`write_sicd` writes for an image product."""
    layout = layout or sicd_layout(image_product)
    pixels = image_product["image"].transpose(layout["row_dim"], layout["col_dim"]).values
    if layout["flip_row"]:
        pixels = pixels[::-1]
    if layout["flip_col"]:
        pixels = pixels[:, ::-1]
    return np.ascontiguousarray(pixels, dtype=np.complex64)


def _oriented(array: np.ndarray, layout: dict) -> np.ndarray:
    if layout["flip_row"]:
        array = array[::-1]
    if layout["flip_col"]:
        array = array[:, ::-1]
    return array


def write_sicd(image_product: xr.Dataset, path: str | os.PathLike, *,
               raw: xr.Dataset | None = None, origin: LabOrigin = DEFAULT_ORIGIN,
               overwrite: bool = False) -> Path:
    """Write a mitsar image product as a SICD 1.4.0 NITF file (module docstring).

    Parameters
    ----------
    image_product : xarray.Dataset
        Image product on a slant or plane grid.
    path : path-like
        Output file (conventionally ``*.nitf``), written atomically.
    raw : xarray.Dataset
        The raw product the image was focused from: SICD needs the collection geometry
        (antenna positions and times), which the image product does not hold.
    origin : LabOrigin
        Where the lab frame sits on the Earth.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    ParameterError
        For a non-image, an image on a points grid, or a missing ``raw``.
    OutputExistsError
        If ``path`` exists and ``overwrite`` is false.
    """
    image = _check_image(image_product)
    if not isinstance(raw, xr.Dataset) or raw.attrs.get("product") != "raw":
        raise ParameterError("write_sicd", "raw", "the raw product the image was focused "
                             "from (SICD needs the antenna positions and times)",
                             None if raw is None else type(raw).__name__)
    if not isinstance(origin, LabOrigin):
        raise ParameterError("write_sicd", "origin", "a LabOrigin", type(origin).__name__)
    sksicd = require_sarkit("sarkit.sicd")
    wgs84 = require_sarkit("sarkit.wgs84")
    etree = require_sarkit("lxml.etree")
    radar = Radar.from_attrs(image.attrs)
    time = np.asarray(raw["slow_time"].values, float) + radar.sweep_duration / 2
    time = time - time[0] + radar.sweep_duration / 2
    arp_lab = np.asarray(raw["platform_position"].values, float)
    mid = len(time) // 2
    layout = sicd_layout(image, arp_lab[mid])
    pixels = sicd_pixels(image, layout)
    rows, cols = pixels.shape
    position = _oriented(image["position"].transpose(layout["row_dim"], layout["col_dim"],
                                                     "xyz").values, layout)
    scp_index = (rows // 2, cols // 2)
    scp_lab = position[scp_index]
    scp = origin.to_ecf(scp_lab)
    order = int(min(5, len(time) - 1))
    arp_poly = np.polynomial.polynomial.polyfit(time, origin.to_ecf(arp_lab), order)
    sight = scp_lab - arp_lab[mid]
    sight /= np.linalg.norm(sight)
    wavenumber = 2.0 * radar.carrier_frequency / SPEED_OF_LIGHT
    window = str(image.attrs.get("window", "rect"))
    range_window = str(image.attrs.get("range_window", window))
    algorithm = str(image.attrs.get("algorithm", "bpa"))

    def grid_dim(u: np.ndarray, spacing: float, resolution: float, weighting: str) -> dict:
        bandwidth = 1.0 / resolution
        half = min(bandwidth / 2, 0.5 / spacing)
        return {"UVectECF": origin.vectors_to_ecf(u), "SS": spacing,
                "ImpRespWid": impulse_width_factor(weighting) / bandwidth, "Sgn": -1,
                "ImpRespBW": bandwidth, "KCtr": wavenumber * float(sight @ u),
                "DeltaK1": -half, "DeltaK2": half,
                "WgtType": {"WindowName": WINDOW_NAMES.get(weighting, weighting.upper())}}

    row_is_range = layout["row_dim"] == image["image"].dims[
        int(np.argmax(np.abs(image.attrs.get("range_axis", [0.0, 1.0]))))]
    row_resolution = float(image.attrs["range_resolution"] if row_is_range
                           else image.attrs["azimuth_resolution"])
    col_resolution = float(image.attrs["azimuth_resolution"] if row_is_range
                           else image.attrs["range_resolution"])
    normal = np.cross(layout["u_row"], layout["u_col"])
    plane = ("SLANT" if image.attrs.get("grid_kind") == "slant"
             else "GROUND" if abs(normal[2]) > 0.999 else "OTHER")
    low = radar.carrier_frequency - radar.bandwidth / 2
    high = radar.carrier_frequency + radar.bandwidth / 2
    corners_lab = [position[0, 0], position[0, -1], position[-1, -1], position[-1, 0]]
    corners = wgs84.cartesian_to_geodetic(origin.to_ecf(np.array(corners_lab)))[:, :2]

    ns = SICD_NAMESPACE
    root = etree.Element(f"{{{ns}}}SICD", nsmap={None: ns})
    xml = sksicd.ElementWrapper(root)
    xml["CollectionInfo"] = {
        "CollectorName": "mitsar FMCW SAR", "CoreName": f"mitsar-{__version__}",
        "CollectType": "MONOSTATIC", "RadarMode": {"ModeType": "STRIPMAP"},
        "Classification": "UNCLASSIFIED"}
    xml["ImageCreation"] = {"Application": f"mitsar {__version__}",
                            "DateTime": _dt.datetime.now(_dt.UTC).replace(microsecond=0)}
    xml["ImageData"] = {"PixelType": "RE32F_IM32F", "NumRows": rows, "NumCols": cols,
                        "FirstRow": 0, "FirstCol": 0,
                        "FullImage": {"NumRows": rows, "NumCols": cols},
                        "SCPPixel": list(scp_index)}
    xml["GeoData"] = {"EarthModel": "WGS_84",
                      "SCP": {"ECF": scp, "LLH": wgs84.cartesian_to_geodetic(scp)},
                      "ImageCorners": corners}
    xml["Grid"] = {
        "ImagePlane": plane, "Type": "PLANE", "TimeCOAPoly": [[float(time[mid])]],
        "Row": grid_dim(layout["u_row"], layout["row_spacing"], row_resolution,
                        range_window if row_is_range else window),
        "Col": grid_dim(layout["u_col"], layout["col_spacing"], col_resolution,
                        window if row_is_range else range_window)}
    xml["Timeline"] = {"CollectStart": COLLECT_START,
                       "CollectDuration": float(time[-1] + radar.sweep_duration / 2)}
    xml["Position"] = {"ARPPoly": arp_poly}
    xml["RadarCollection"] = {
        "TxFrequency": {"Min": low, "Max": high},
        "Waveform": {"WFParameters": [{
            "TxPulseLength": radar.sweep_duration, "TxRFBandwidth": radar.bandwidth,
            "TxFreqStart": low, "TxFMRate": radar.chirp_rate, "RcvDemodType": "STRETCH",
            "RcvWindowLength": radar.sweep_duration, "ADCSampleRate": radar.sampling_frequency,
            "RcvFMRate": radar.chirp_rate}]},
        "TxPolarization": "V",
        "RcvChannels": {"ChanParameters": [{"TxRcvPolarization": "V:V"}]}}
    xml["ImageFormation"] = {
        "RcvChanProc": {"NumChanProc": 1, "ChanIndex": [1]},
        "TxRcvPolarizationProc": "V:V", "TStartProc": float(time[0]),
        "TEndProc": float(time[-1]), "TxFrequencyProc": {"MinProc": low, "MaxProc": high},
        "ImageFormAlgo": ALGORITHMS.get(algorithm, "OTHER"), "STBeamComp": "NO",
        "ImageBeamComp": "NO", "AzAutofocus": "NO", "RgAutofocus": "NO"}
    parameters = {**origin.to_parameters(), "mitsar.algorithm": algorithm,
                  "mitsar.row_dim": str(layout["row_dim"]),
                  "mitsar.col_dim": str(layout["col_dim"]),
                  "mitsar.flip_row": str(int(layout["flip_row"])),
                  "mitsar.flip_col": str(int(layout["flip_col"])),
                  **{k: repr(v) for k, v in image.attrs.items() if k.startswith("radar_")}}
    for parent, child in (("RadarCollection/{ns}Waveform", "WFParameters"),
                          ("RadarCollection/{ns}RcvChannels", "ChanParameters")):
        node = root.find(f"{{{ns}}}" + parent.format(ns=f"{{{ns}}}"))
        node.set("size", str(len(node)))
        for index, item in enumerate(node.findall(f"{{{ns}}}{child}"), start=1):
            item.set("index", str(index))
    info = root.find(f"{{{ns}}}CollectionInfo")
    for key, value in parameters.items():
        etree.SubElement(info, f"{{{ns}}}Parameter", name=key).text = value
    tree = etree.ElementTree(root)
    xml["SCPCOA"] = sksicd.compute_scp_coa(tree)
    security = sksicd.NitfSecurityFields(clas="U")
    metadata = sksicd.NitfMetadata(
        xmltree=tree,
        file_header_part=sksicd.NitfFileHeaderPart(ostaid="mitsar", security=security),
        im_subheader_part=sksicd.NitfImSubheaderPart(isorce="mitsar FMCW SAR",
                                                     security=security),
        de_subheader_part=sksicd.NitfDeSubheaderPart(security=security))

    def write(tmp: Path) -> None:
        with tmp.open("wb") as handle, sksicd.NitfWriter(handle, metadata) as writer:
            writer.write_image(pixels)

    return atomic_writer(path, overwrite, write)
