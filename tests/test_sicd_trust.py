"""SICD that other readers trust (issue 25 items 1 and 4): the grid metadata describe the pixels.

Judged by sarpy 2.1 (the test extra): its ``fft_sicd`` (the DFT of the pixels with the exponent
sign ``Grid/{Row,Col}/Sgn``, NGA.STND.0024-1 SICD Vol. 1 §4.2) puts >= 95 % of the row and of
the column spectral energy inside ``[DeltaK1, DeltaK2]`` (on the curved, wandering flight too:
its pixels are band-limited in the image, :mod:`mitsar.focus.band_limit`), its SICD model finds
the metadata valid, and it rebuilds the window from
``WgtType``; ``TimeCOAPoly`` at the SCP lies within one sweep of the geometric centre of
aperture (Vol. 1 §4.3); sarkit's ``sicdcheck`` exits 0.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mitsar
from mitsar.export import DEFAULT_ORIGIN, write_sicd
from mitsar.focus.aperture import aspect_frames

sksicd = pytest.importorskip("sarkit.sicd", reason="needs sarkit (pip install mitsar[nga])")

SICDCHECK = Path(sys.executable).parent / "sicdcheck"
OSR_CHECKS = "check_iprbw_to_ss_osr.*"
"""sarkit's wish for an oversampling ratio 1/(ImpRespBW SS) in [1.1, 2.2]: the paper's grid
samples a 0.1 m resolution at 0.01 m (ratio 10) by design, so that Warning is not about the
metadata; :func:`test_sicdcheck_exits_0_at_a_nominal_sampling` runs the checker unfiltered."""


def _paper(step: float = 0.01):
    """The paper's point-target geometry (examples/paper_point_target.toml), analytic."""
    raw = mitsar.simulate_point_targets(
        mitsar.Radar(), mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], 2.4),
        mitsar.Look(55.71), [mitsar.PointTarget([15.0, 8.0, 0.0])], normalized=True)
    grid = mitsar.grid.SlantGrid(along_track=[-0.4, 0.8, step], slant_range=[6.99, 8.99, step])
    return raw, mitsar.focus(raw, algorithm="bpa", window="rect", azimuth_resolution=0.1,
                             grid=grid)


def _curved(curve: float = 0.04):
    """A curved flight (``curve`` m sideways over 2.4 s) that wanders (3 cm at 0.8 s across,
    1 cm at 1.1 s in height: the velocity swings by +-25 deg), two targets, BPA with the band
    selected in the image (a wider per-pixel aperture, then the band about each pixel's centre
    of aperture: mitsar.focus.band_limit)."""
    t = np.linspace(0.0, 2.4, 241)
    wave, bob = 2 * np.pi / 0.8, 2 * np.pi / 1.1
    position = np.c_[14.8 + 0.5 * t, 1.4 + curve * (t / 2.4) ** 2 + 0.03 * np.sin(wave * t),
                     4.5 + 0.01 * np.sin(bob * t)]
    velocity = np.c_[0.5 + 0 * t, 2 * curve * t / 2.4 ** 2 + 0.03 * wave * np.cos(wave * t),
                     0.01 * bob * np.cos(bob * t)]
    raw = mitsar.simulate_point_targets(
        mitsar.Radar(), mitsar.Trajectory.navigation(t, position, velocity), mitsar.Look(55.71),
        [mitsar.PointTarget([15.4, 8.0, 0.0]), mitsar.PointTarget([15.7, 8.2, 0.0])],
        normalized=True)
    grid = mitsar.grid.SlantGrid(along_track=[0.2, 1.4, 0.01], slant_range=[6.99, 8.99, 0.01])
    image = mitsar.focus(raw, algorithm="bpa", window="rect", azimuth_resolution=0.1,
                         grid=grid)
    assert image.attrs["band_limit"] == "image"
    return raw, image


@pytest.fixture(scope="module", params=["paper", "curved", "wander"])
def product(request, tmp_path_factory):
    """The paper's straight track, the curved wandering flight, and its wander alone."""
    raw, image = {"paper": _paper, "curved": _curved,
                  "wander": lambda: _curved(0.0)}[request.param]()
    path = write_sicd(image, tmp_path_factory.mktemp("sicd") / "image.nitf", raw=raw)
    with path.open("rb") as handle, sksicd.NitfReader(handle) as reader:
        pixels = reader.read_image()
        xml = reader.metadata.xmltree
    return request.param, raw, path, pixels, xml


def _value(xml, path: str) -> float:
    return float(xml.findtext(path))


def _poly(xml, path: str) -> np.ndarray:
    node = xml.find(path)
    coefficients = np.zeros((int(node.get("order1")) + 1, int(node.get("order2")) + 1))
    for term in node:
        coefficients[int(term.get("exponent1")), int(term.get("exponent2"))] = float(term.text)
    return coefficients


def sarpy_reader(path: Path):
    """sarpy's reader of a SICD file (skips without sarpy: it is in the test extra)."""
    pytest.importorskip("sarpy", reason="needs sarpy 2.1 (pip install mitsar[test])")
    import warnings

    from sarpy.io.complex.converter import open_complex

    with warnings.catch_warnings():  # "sarpy's SICD implementation is deprecated" (sarkit's)
        warnings.simplefilter("ignore", DeprecationWarning)
        return open_complex(str(path))


def support_fractions(path: Path) -> dict[str, float]:
    """Fraction of the row / column spectral energy inside [DeltaK1, DeltaK2] (cyc/m), the
    spectrum taken by sarpy's ``fft_sicd`` (forward DFT for Sgn = -1, inverse for +1) of the
    pixels sarpy reads, the frequencies of its bins ``fftfreq(n, SS)``."""
    from sarpy.processing.sicd.fft_base import fft_sicd

    reader = sarpy_reader(path)
    sicd, pixels = reader.get_sicds_as_tuple()[0], reader[:, :]
    fractions = {}
    for axis, (name, grid) in enumerate((("Row", sicd.Grid.Row), ("Col", sicd.Grid.Col))):
        power = (np.abs(fft_sicd(pixels, axis, sicd)) ** 2).sum(axis=1 - axis)
        frequency = np.fft.fftfreq(pixels.shape[axis], grid.SS)
        inside = (frequency >= grid.DeltaK1) & (frequency <= grid.DeltaK2)
        fractions[name] = float(power[inside].sum() / power.sum())
    return fractions


def test_spectral_energy_inside_the_declared_support(product):
    name, _, path, pixels, xml = product
    reader = sarpy_reader(path)
    np.testing.assert_array_equal(reader[:, :], pixels)  # sarpy and sarkit read the same
    fractions = support_fractions(path)
    # The issue asks 0.95. Measured: paper row 0.9986, col 0.9980; curved row 0.9984, col
    # 0.9996; wander alone row 0.9985, col 0.9968 (0.9492 and 0.7901 with the sliding
    # per-pixel band: its response sinc(B d) exp(j pi k d^2/R) is not band-limited,
    # test_a_sliding_aperture_is_not_band_limited; the band is now selected in the image,
    # mitsar.focus.band_limit; and the support's extremes along the image's edges are
    # declared through ValidData, docs/products.md).
    assert fractions["Row"] >= 0.95
    assert fractions["Col"] >= 0.95
    for dim in ("Row", "Col"):  # a real support, not the whole band
        width = (_value(xml, f"{{*}}Grid/{{*}}{dim}/{{*}}DeltaK2")
                 - _value(xml, f"{{*}}Grid/{{*}}{dim}/{{*}}DeltaK1"))
        assert width < 0.5 / _value(xml, f"{{*}}Grid/{{*}}{dim}/{{*}}SS")


def test_sarpy_finds_the_metadata_valid(product, caplog):
    """sarpy's SICD model checks (``SICDType.is_valid``: DeltaK against DeltaKCOAPoly and
    ImpRespBW, the polynomials, SCPCOA against the geometry, ...) log no error. (sarpy's
    ``sicd_consistency.check_file`` stops earlier: sarpy 2.1 maps no SICD 1.4.0 urn.)"""
    import logging

    reader = sarpy_reader(product[2])
    with caplog.at_level(logging.INFO, logger="validation"):
        valid = reader.get_sicds_as_tuple()[0].is_valid(recursive=True, stack=False)
    errors = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
    assert valid and errors == []
    assert "TimeCOAPoly is scalar" not in caplog.text  # the warning, gone
    assert "No Timeline.IPP" not in caplog.text  # the sweep rate is there for its analyses


def test_time_coa_at_the_scp_is_its_centre_of_aperture(product):
    name, raw, _, _, xml = product
    radar = mitsar.Radar.from_attrs(raw.attrs)
    sweep = 1.0 / radar.prf
    scp = DEFAULT_ORIGIN.from_ecf([_value(xml, f"{{*}}GeoData/{{*}}SCP/{{*}}ECF/{{*}}{a}")
                                   for a in "XYZ"])
    time = np.asarray(raw["slow_time"].values) + radar.sweep_duration / 2
    positions = np.asarray(raw["platform_position"].values)
    if name == "paper":  # straight, unsquinted: broadside, x_scp = x_0 + v t
        expected = (scp[0] - positions[0, 0]) / 0.5 + radar.sweep_duration / 2
    else:  # the focuser's own aspect frame: the sweep where d . l = u (mitsar.focus.aperture)
        velocities = np.asarray(raw["platform_velocity"].values)
        unit = velocities / np.linalg.norm(velocities, axis=1, keepdims=True)
        centroid = np.einsum("si,si->s", np.asarray(raw["boresight"].values), unit)
        direction, sine = aspect_frames(scp[None], positions, velocities, centroid)
        sight = scp - positions
        offset = sight @ direction[0] / np.linalg.norm(sight, axis=1) - sine[0]
        k = int(np.flatnonzero(np.diff(np.sign(offset)))[0])
        expected = time[k] + offset[k] / (offset[k] - offset[k + 1]) * sweep
    poly = _poly(xml, "{*}Grid/{*}TimeCOAPoly")
    assert abs(poly[0, 0] - expected) < sweep
    assert _value(xml, "{*}SCPCOA/{*}SCPTime") == pytest.approx(poly[0, 0], abs=1e-9)
    assert poly.size > 1 and np.abs(poly[:, 1:]).max() > 1.0  # varies along the track


def test_sicdcheck_exits_0(product):
    if not SICDCHECK.exists():
        pytest.skip("sarkit's sicdcheck script not installed beside this Python")
    _, _, path, _, _ = product
    result = subprocess.run([str(SICDCHECK), str(path), "--ignore", OSR_CHECKS],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout[-3000:]


def test_sicdcheck_exits_0_at_a_nominal_sampling(tmp_path):
    if not SICDCHECK.exists():
        pytest.skip("sarkit's sicdcheck script not installed beside this Python")
    raw, image = _paper(step=0.05)  # 0.1 m resolution at 0.05 m: oversampling 2.0
    path = write_sicd(image, tmp_path / "image.nitf", raw=raw)
    result = subprocess.run([str(SICDCHECK), str(path)], capture_output=True, text=True,
                            check=False)
    assert result.returncode == 0, result.stdout[-3000:]


def test_a_sliding_aperture_is_not_band_limited(tmp_path, monkeypatch):
    """Why a 2-D image off a straight track has its band selected in the image
    (mitsar.focus.band_limit): "pixel" band selection alone (as a straight track gets it here,
    and any track on a PointsGrid) centres each pixel's aperture on the pixel, so a point's
    response is
    ``sinc(B d) exp(j pi k d^2 / R)`` (d along the columns, B = 1/rho, k = 2 f_c / c): not
    band-limited to B. On the paper's straight track, whose "doppler" selection is band-limited,
    the same image with "pixel" selection keeps in [DeltaK1, DeltaK2] about the closed form's
    fraction of that kernel's energy (measured 0.853 vs 0.825 closed form at 0.02 m pixels: the
    antenna pattern weights the sidelobes down), against 0.998 with "doppler"."""
    import functools
    import importlib

    from mitsar.focus.bpa import focus_bpa

    dispatch = importlib.import_module("mitsar.focus.dispatch")
    raw = _paper()[0]
    step = 0.02
    grid = mitsar.grid.SlantGrid(along_track=[-0.4, 0.8, step], slant_range=[7.5, 8.5, step])
    fractions = {}
    for selection in ("doppler", "pixel"):
        monkeypatch.setattr(dispatch, "focus_bpa",
                            functools.partial(focus_bpa, band_selection=selection))
        image = mitsar.focus(raw, algorithm="bpa", window="rect", azimuth_resolution=0.1,
                             grid=grid)
        assert image.attrs["band_selection"] == selection
        path = write_sicd(image, tmp_path / f"{selection}.nitf")
        fractions[selection] = support_fractions(path)["Col"]
        columns = image.sizes["azimuth"]
    target = np.array([15.0, 8.0, 0.0])
    slant = float(np.linalg.norm(target - [15.0, 1.4, 4.5]))
    wavenumber = 2 * mitsar.Radar().carrier_frequency / 299_792_458.0
    offset = (np.arange(columns) - columns // 2) * step  # the image's columns, target centred
    kernel = np.sinc(10.0 * offset) * np.exp(1j * np.pi * wavenumber * offset ** 2 / slant)
    power = np.abs(np.fft.fft(kernel)) ** 2
    closed = float(power[np.abs(np.fft.fftfreq(columns, step)) <= 5.0].sum() / power.sum())
    assert fractions["doppler"] >= 0.99
    assert closed - 0.01 <= fractions["pixel"] <= closed + 0.05
    assert fractions["pixel"] < 0.9


def _spectral_shape(pixels: np.ndarray, axis: int, centre: float, spacing: float,
                    bandwidth: float, positions: np.ndarray) -> np.ndarray:
    """|spectrum| of the pixels along ``axis`` (Sgn = +1: the inverse DFT), summed over the
    other axis, at ``positions`` in [0, 1] across [centre - bandwidth/2, centre + bandwidth/2]
    (cyc/m, wrapped modulo 1/spacing), normalised to its largest value there."""
    size = 4096
    spectrum = np.abs(np.fft.ifft(pixels, n=size, axis=axis)) ** 2
    power = np.sqrt(spectrum.sum(axis=1 - axis))
    frequency = np.fft.fftfreq(size, spacing)
    wanted = (centre + bandwidth * (positions - 0.5) + 0.5 / spacing) % (1 / spacing) \
        - 0.5 / spacing
    order = np.argsort(frequency)
    shape = np.interp(wanted, frequency[order], power[order])
    return shape / shape.max()


def test_weighting_is_the_window_applied(tmp_path):
    """WgtType/WgtFunct (issue 25 item 4) describe the windows focus applied: WgtFunct is the
    window mitsar evaluates, sarpy rebuilds it from WgtType's name and parameters, and the
    pixels' own spectra follow the declared weighting of each axis (Taylor in azimuth =
    columns, Hamming in range = rows), closer to it than to the other axis' window."""
    from mitsar.export.sicd import WEIGHT_SAMPLES
    from mitsar.focus.windows import evaluate_window, window_coefficients

    raw = _paper()[0]
    grid = mitsar.grid.SlantGrid(along_track=[-0.4, 0.8, 0.02], slant_range=[7.0, 9.0, 0.02])
    image = mitsar.focus(raw, algorithm="bpa", window="taylor", range_window="hamming",
                         azimuth_resolution=0.1, grid=grid)
    path = write_sicd(image, tmp_path / "weighted.nitf")
    with path.open("rb") as handle, sksicd.NitfReader(handle) as reader:
        pixels = reader.read_image().astype(complex)
        xml = reader.metadata.xmltree
    if SICDCHECK.exists():  # WgtFunct's indices and sizes as sarkit reads them
        result = subprocess.run([str(SICDCHECK), str(path), "--ignore", OSR_CHECKS],
                                capture_output=True, text=True, check=False)
        assert result.returncode == 0, result.stdout[-3000:]
    x = np.linspace(0.0, 1.0, WEIGHT_SAMPLES)
    declared = {}
    for dim, window, name in (("Row", "hamming", "HAMMING"), ("Col", "taylor", "TAYLOR")):
        assert xml.findtext(f"{{*}}Grid/{{*}}{dim}/{{*}}WgtType/{{*}}WindowName") == name
        weights = np.array([float(w.text) for w in
                            xml.findall(f"{{*}}Grid/{{*}}{dim}/{{*}}WgtFunct/{{*}}Wgt")])
        np.testing.assert_allclose(weights, evaluate_window(window_coefficients(window), x),
                                   rtol=1e-12)
        declared[dim] = weights
    sicd = sarpy_reader(path).get_sicds_as_tuple()[0]
    # sarpy rebuilds a window from WgtType alone with SciPy: general_hamming(sym=True) samples
    # the band's ends included, taylor(sym=True) the centres of N equal cells
    where = {"Row": x, "Col": (np.arange(WEIGHT_SAMPLES) + 0.5) / WEIGHT_SAMPLES}
    for dim, window, grid_dim in (("Row", "hamming", sicd.Grid.Row),
                                  ("Col", "taylor", sicd.Grid.Col)):
        grid_dim.WgtFunct = None
        rebuilt = grid_dim.define_weight_function(weight_size=WEIGHT_SAMPLES)
        ours = evaluate_window(window_coefficients(window), where[dim])
        np.testing.assert_allclose(rebuilt / rebuilt.max(), ours / ours.max(), atol=1e-6)
    # The pixels' spectra across the band (the interior 80 %: the band edges are smeared by
    # the image's finite extent, 1/(1.2 m) = 0.8 cyc/m of 10 cyc/m)
    inner = np.linspace(0.1, 0.9, 17)
    measured = {}
    for axis, dim in enumerate(("Row", "Col")):
        centre = _poly(xml, f"{{*}}Grid/{{*}}{dim}/{{*}}DeltaKCOAPoly")[0, 0]
        measured[dim] = _spectral_shape(
            pixels, axis, centre, _value(xml, f"{{*}}Grid/{{*}}{dim}/{{*}}SS"),
            _value(xml, f"{{*}}Grid/{{*}}{dim}/{{*}}ImpRespBW"), inner)
    def error(shape: np.ndarray, weights: np.ndarray) -> float:
        model = np.interp(inner, x, weights)
        return float(np.sqrt(np.mean((shape - model / model.max()) ** 2)))

    # measured RMS: rows 0.004 against Hamming, 0.069 against Taylor; columns 0.028 against
    # Taylor, 0.063 against Hamming; 0.42-0.48 against a uniform window
    for dim, other in (("Row", "Col"), ("Col", "Row")):
        assert error(measured[dim], declared[dim]) < 0.05
        assert error(measured[dim], declared[dim]) < 0.5 * error(measured[dim], declared[other])


def _patch_sigma0(seed: int, sigma0: float, path: Path) -> tuple[float, float, int]:
    """A flat distributed patch (1.6 m square on z = 0, 3000 random points of equal RCS,
    sigma0 per unit ground area), imaged with the whole aperture; returns (sum of pixel power
    x SigmaZeroSF read through sarkit, the same read through sarpy, pixels) over the image."""
    rng = np.random.default_rng(seed)
    points, size = 3000, 1.6
    xy = rng.uniform(-size / 2, size / 2, (points, 2)) + [14.9, 8.0]
    targets = [mitsar.PointTarget([x, y, 0.0], sigma0 * size ** 2 / points) for x, y in xy]
    raw = mitsar.simulate_point_targets(
        mitsar.Radar(), mitsar.Trajectory.linear([13.8, 1.4, 4.5], [0.5, 0, 0], 4.0),
        mitsar.Look(55.71), targets, normalized=False)
    grid = mitsar.grid.SlantGrid(along_track=[0.5, 1.3, 0.02], slant_range=[7.6, 8.4, 0.02])
    image = mitsar.focus(raw, algorithm="bpa", window="rect", azimuth_resolution=0.1,
                         grid=grid)
    assert float(image["coverage"].min()) > 0.999  # every pixel has its whole aperture
    write_sicd(image, path, raw=raw, overwrite=True)
    with path.open("rb") as handle, sksicd.NitfReader(handle) as reader:
        pixels = reader.read_image().astype(complex)
        xml = reader.metadata.xmltree
    poly = _poly(xml, "{*}Radiometric/{*}SigmaZeroSFPoly")
    rows, cols = pixels.shape
    xrow = (np.arange(rows) - rows // 2) * _value(xml, "{*}Grid/{*}Row/{*}SS")
    ycol = (np.arange(cols) - cols // 2) * _value(xml, "{*}Grid/{*}Col/{*}SS")
    scale = np.polynomial.polynomial.polygrid2d(xrow, ycol, poly)
    beta = _poly(xml, "{*}Radiometric/{*}BetaZeroSFPoly")
    rcs = _poly(xml, "{*}Radiometric/{*}RCSSFPoly")
    bandwidth = (_value(xml, "{*}Grid/{*}Row/{*}ImpRespBW")
                 * _value(xml, "{*}Grid/{*}Col/{*}ImpRespBW"))
    assert beta[0, 0] == pytest.approx(rcs[0, 0] * bandwidth, rel=1e-9)
    # sarpy reads the same file with its own SICD model: its pixels, grid and SigmaZeroSFPoly
    reader = sarpy_reader(path)
    sicd, seen = reader.get_sicds_as_tuple()[0], reader[:, :].astype(complex)
    row_ss, col_ss = sicd.Grid.Row.SS, sicd.Grid.Col.SS
    scp_row, scp_col = sicd.ImageData.SCPPixel.Row, sicd.ImageData.SCPPixel.Col
    x, y = np.meshgrid((np.arange(seen.shape[0]) - scp_row) * row_ss,
                       (np.arange(seen.shape[1]) - scp_col) * col_ss, indexing="ij")
    by_sarpy = float((np.abs(seen) ** 2 * sicd.Radiometric.SigmaZeroSFPoly(x, y)).sum())
    return float((np.abs(pixels) ** 2 * scale).sum()), by_sarpy, pixels.size


@pytest.mark.slow
def test_radiometric_sigma0_of_a_flat_patch(tmp_path):
    """sigma0 from Radiometric/SigmaZeroSFPoly (mitsar's radar equation, NGA Vol. 1 §4.10),
    read by sarkit and by sarpy, within 0.5 dB of the scene's: the mean over three speckle
    realisations (one realisation scatters by +-0.5 dB over ~130 resolution cells; measured
    +0.31, -0.22, +0.07 dB each, +0.06 dB together, the same through sarpy)."""
    sigma0 = 0.1
    totals = [_patch_sigma0(seed, sigma0, tmp_path / f"patch{seed}.nitf") for seed in (1, 2, 3)]
    count = sum(n for *_, n in totals)
    for reader in (0, 1):  # sarkit, sarpy
        estimate = sum(t[reader] for t in totals) / count
        assert abs(10 * np.log10(estimate / sigma0)) < 0.5
