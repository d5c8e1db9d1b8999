"""Tests of mitsar.quality against closed forms of the rectangular-spectrum impulse response.

Closed forms (sinc, Cumming & Wong 2005 §2.6; docs/design.md §5.7): IRW 0.8859 cells,
PSLR −13.26 dB, ISLR −9.68 dB (infinite), −10.69 dB (±5 cells), −10.16 dB (±10 cells);
Hamming (0.54) IRW 1.303 cells.

Test responses are Dirichlet kernels (a rectangular spectrum of M bins on N samples), which are
exactly band-limited and periodic; they differ from the sinc by O((x/M)²), which is where most of
the tolerance goes.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from scipy.special import sici

from mitsar.quality import (
    band_fill_db,
    first_nulls,
    irw,
    islr_db,
    measure_cut,
    measure_impulse_response,
    pslr_db,
    upsample_chip,
    upsample_cut,
)

IRW_RECT = 0.8859
PSLR_RECT = -13.26
ISLR_RECT = {"inf": -9.68, "paper": -10.69, 10.0: -10.16}
IRW_HAMMING = 1.303


def dirichlet(
    n: int, m: int, centre: float, *, shift_bins: float = 0.0, hamming: bool = False
) -> np.ndarray:
    """Unit-peak response of M spectral bins sampled on N points (N/M samples per cell).

    ``centre`` is the (sub-sample) peak position, ``shift_bins`` moves the spectrum off zero
    frequency (a squinted/offset spectrum, which may wrap around the band edge). The bins are
    whole DFT bins, so the response is exactly periodic over N samples.
    """
    bins = np.arange(m) - m // 2 + shift_bins
    # Midpoint sampling of the continuous Hamming weighting 0.54 + 0.46 cos(2πf/B).
    f = (np.arange(m) - (m - 1) / 2) / m
    w = 0.54 + 0.46 * np.cos(2 * np.pi * f) if hamming else np.ones(m)
    return np.exp(2j * np.pi * np.outer(np.arange(n) - centre, bins) / n) @ w / w.sum()


def sinc_islr_db(extent_cells: float) -> float:
    """Closed-form ISLR of sinc² with sidelobes to ± ``extent_cells`` (null-to-null main lobe).

    ∫₀ᴸ sinc²(x) dx = Si(2πL)/π − sin²(πL)/(π²L) (integration by parts).
    """

    def energy(half_width: float) -> float:
        si = sici(2 * np.pi * half_width)[0]
        return 2 * (si / np.pi - np.sin(np.pi * half_width) ** 2 / (np.pi**2 * half_width))

    return 10 * math.log10(energy(extent_cells) / energy(1.0) - 1)


def islr_2d_separable(islr_range_db: float, islr_azimuth_db: float) -> float:
    """2-D ISLR of a separable response from its two 1-D ISLRs (same extent, rectangle main lobe).

    Main-lobe and box energies factor into products of the 1-D ones: (1 + r_r)(1 + r_a) − 1.
    """
    r_r, r_a = 10 ** (islr_range_db / 10), 10 ** (islr_azimuth_db / 10)
    return 10 * math.log10((1 + r_r) * (1 + r_a) - 1)


SINC_ISLR_2D_PAPER = islr_2d_separable(sinc_islr_db(5), sinc_islr_db(5))  # −7.5022 dB


def test_sinc_closed_forms() -> None:
    # The reference numbers used above are the closed forms (notes §2, to their rounding).
    assert sinc_islr_db(5) == pytest.approx(-10.6938, abs=1e-4)
    assert sinc_islr_db(10) == pytest.approx(-10.1584, abs=1e-4)
    assert sinc_islr_db(11) == pytest.approx(-10.1127, abs=1e-4)
    assert sinc_islr_db(1e7) == pytest.approx(-9.6804, abs=1e-4)


# ----------------------------------------------------------------------------------------------
# 1-D cuts
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("n", "m", "centre", "shift_bins"),
    [
        (256, 128, 128.0, 0.0),  # 0.5 cell per sample, peak on a sample
        (256, 128, 97.37, 0.0),  # sub-sample offset
        (256, 128, 140.81, 101.0),  # offset spectrum wrapping round the band edge (basebanding)
        (128, 127, 63.29, 0.0),  # ≈ 1 sample per cell (0.992): one empty bin at Nyquist
    ],
)
def test_rect_spectrum_cut(n: int, m: int, centre: float, shift_bins: float) -> None:
    cut = dirichlet(n, m, centre, shift_bins=shift_bins)
    spacing = m / n  # resolution cells per sample
    fine = upsample_cut(cut, 32)
    fine_spacing = spacing / 32
    # Tolerances: Dirichlet M≈128 vs sinc differ by ≤ 0.0005 cells, 0.003 dB (PSLR) and
    # 0.005 dB (±5), 0.009 dB (±10) and 0.001 dB (inf) in ISLR; the 32× interpolation
    # adds < 1e-4 cells and < 1e-3 dB. The brief's tolerances cover both with margin.
    assert irw(fine, fine_spacing) == pytest.approx(0.886, abs=0.002)
    assert pslr_db(fine) == pytest.approx(PSLR_RECT, abs=0.01)
    assert islr_db(fine, fine_spacing, "inf") == pytest.approx(ISLR_RECT["inf"], abs=0.02)
    assert islr_db(fine, fine_spacing, "chip") == islr_db(fine, fine_spacing, "inf")
    assert islr_db(fine, fine_spacing, "paper") == pytest.approx(ISLR_RECT["paper"], abs=0.01)
    assert islr_db(fine, fine_spacing, 10.0) == pytest.approx(ISLR_RECT[10.0], abs=0.02)
    # First nulls of a rectangular spectrum at ±1 cell (±N/M samples, exact for a Dirichlet);
    # parabolic refinement on 32× samples is good to ~1e-3 cells.
    left, right = first_nulls(fine, fine_spacing)
    assert left == pytest.approx(-1.0, abs=2e-3)
    assert right == pytest.approx(1.0, abs=2e-3)
    # measure_cut with its own upsampling agrees with the separate functions.
    metrics = measure_cut(cut, spacing, "paper", upsample=32)
    assert metrics["irw_cells"] == pytest.approx(irw(fine, fine_spacing), rel=1e-12)
    assert metrics["islr_db"] == pytest.approx(islr_db(fine, fine_spacing), rel=1e-12)
    # The refined peak is where it was planted (in cells from the first sample); any residual
    # is from the parabola on 32× samples, ≲ 1e-3 cells.
    assert metrics["peak_cells"] == pytest.approx(centre * spacing, abs=2e-3)


@pytest.mark.parametrize("centre", [128.0, 101.63])
def test_hamming_cut(centre: float) -> None:
    cut = dirichlet(256, 128, centre, hamming=True)
    metrics = measure_cut(cut, 0.5, "inf", upsample=32)
    # Continuous Hamming: IRW 1.3030 cells; M = 128 midpoint sampling is within 1e-4 of it.
    assert metrics["irw_cells"] == pytest.approx(IRW_HAMMING, abs=0.003)
    # PSLR −42.67 dB (continuous); discretisation moves such low sidelobes by a few 0.01 dB.
    assert metrics["pslr_db"] == pytest.approx(-42.67, abs=0.1)


def test_power_cut_equals_complex_cut() -> None:
    fine = upsample_cut(dirichlet(256, 128, 111.4), 32)
    for extent in ("paper", "isce3", "chip", 7.5):
        assert measure_cut(np.abs(fine) ** 2, 1 / 64, extent) == measure_cut(fine, 1 / 64, extent)


def test_upsampling_is_band_limited_interpolation() -> None:
    # Periodic band-limited input: every 32nd upsampled sample is an original sample (magnitude;
    # the phase ramp of the spectral centroid is removed), to rounding error, with or without
    # the gap taper (the gap is empty).
    cut = dirichlet(64, 24, 30.3, shift_bins=20.0)
    for band in (None, 24 / 64):
        fine = upsample_cut(cut, 32, band=band)
        assert np.allclose(np.abs(fine[::32]), np.abs(cut), atol=1e-12)
    chip = np.outer(dirichlet(20, 10, 9.7), dirichlet(24, 12, 11.2, shift_bins=9.0))
    fine = upsample_chip(chip, 8, band=(0.5, 0.5))
    assert fine.shape == (160, 192)
    assert np.allclose(np.abs(fine[::8, ::8]), np.abs(chip), atol=1e-12)


@pytest.mark.parametrize("half", [32, 33])
def test_chip_truncation_error(half: int) -> None:
    # A ±16-cell chip cut out of a sinc (0.5 cell per pixel) is not periodic. Against the
    # analytic sinc within ±6 cells of the peak: plain zero-padding leaves ~3e-4 (the periodic
    # kernel reaches the samples missing beyond the edges); the gap taper, ≲ 1e-5.
    centre = np.array([half + 0.37, half - 0.21])
    grid = np.arange(2 * half + 1)
    chip = np.outer(np.sinc((grid - centre[0]) / 2), np.sinc((grid - centre[1]) / 2))
    fine_grid = np.arange((2 * half + 1) * 8) / 8
    truth = np.abs(
        np.outer(np.sinc((fine_grid - centre[0]) / 2), np.sinc((fine_grid - centre[1]) / 2))
    )
    near = np.abs(fine_grid - half) < 12
    window = np.ix_(near, near)
    plain = np.abs(upsample_chip(chip, 8))[window] - truth[window]
    tapered = np.abs(upsample_chip(chip, 8, band=0.5))[window] - truth[window]
    assert np.max(np.abs(plain)) > 1e-4
    assert np.max(np.abs(tapered)) < 2e-5


def test_cut_errors() -> None:
    cut = dirichlet(64, 32, 31.0)
    with pytest.raises(ValueError, match="islr_extent") as info:
        islr_db(cut, 0.5, "wide")
    for word in ("'paper'", "'isce3'", "'chip'", "'inf'", "'wide'"):
        assert word in str(info.value)
    with pytest.raises(ValueError, match="islr_extent"):
        measure_cut(cut, 0.5, -3.0)
    with pytest.raises(ValueError, match="non-negative"):
        irw(cut.real, 0.5)
    with pytest.raises(ValueError, match="positive integer"):
        upsample_cut(cut, 0)


# ----------------------------------------------------------------------------------------------
# Image products
# ----------------------------------------------------------------------------------------------


def slant_image(
    peak_index: tuple[float, float], shape: tuple[int, int] = (160, 128), squint: float = 0.0
) -> tuple[xr.Dataset, list[float]]:
    """Separable sinc on an (azimuth, range) slant grid, 0.05 m pixels (0.5 cell), 0.1 m cells.

    ``squint`` (cycles/m) shifts the azimuth spectrum; 7.1 cycles/m moves its 10 cycles/m band
    across the 10 cycles/m Nyquist frequency, so it wraps. Returns the dataset and the world
    position of the planted peak (pixel position = (azimuth, range, 0)).
    """
    pixel, cell = 0.05, 0.1
    azimuth = -2.0 + pixel * np.arange(shape[0])
    rng = 20.0 + pixel * np.arange(shape[1])
    a0 = azimuth[0] + pixel * peak_index[0]
    r0 = rng[0] + pixel * peak_index[1]
    amp = np.outer(
        np.sinc((azimuth - a0) / cell) * np.exp(2j * np.pi * squint * (azimuth - a0)),
        np.sinc((rng - r0) / cell),
    )
    position = np.stack(np.broadcast_arrays(azimuth[:, None], rng[None, :], 0.0), axis=-1)
    ds = xr.Dataset(
        {
            "image": (("azimuth", "range"), amp),
            "position": (("azimuth", "range", "xyz"), position),
        },
        coords={"azimuth": azimuth, "range": rng, "xyz": ["x", "y", "z"]},
        attrs={
            "range_resolution": cell,
            "azimuth_resolution": cell,
            "range_axis": (0.0, 1.0),
            "azimuth_axis": (1.0, 0.0),
        },
    )
    return ds, [a0, r0, 0.0]


def rotated_image(
    angle_deg: float, peak_yx: tuple[float, float], res_range: float, res_azimuth: float
) -> xr.Dataset:
    """Planar (y, x) grid holding a 2-D sinc whose range axis is rotated by ``angle_deg``.

    The response sinc(u/ρ_r) sinc(v/ρ_a) with u, v along the rotated axes is band-limited to a
    rotated rectangle that 0.05 m pixels sample without aliasing for these resolutions.
    """
    pixel = 0.05
    y = -3.2 + pixel * np.arange(128)
    x = 1.0 + pixel * np.arange(136)
    theta = np.deg2rad(angle_deg)
    range_axis = np.array([np.sin(theta), np.cos(theta)])  # (y, x) components
    azimuth_axis = np.array([np.cos(theta), -np.sin(theta)])
    dy = y[:, None] - peak_yx[0]
    dx = x[None, :] - peak_yx[1]
    u = range_axis[0] * dy + range_axis[1] * dx
    v = azimuth_axis[0] * dy + azimuth_axis[1] * dx
    amp = (np.sinc(u / res_range) * np.sinc(v / res_azimuth)).astype(complex)
    position = np.stack(np.broadcast_arrays(x[None, :], y[:, None], 1.5), axis=-1)
    return xr.Dataset(
        {"image": (("y", "x"), amp), "position": (("y", "x", "xyz"), position)},
        coords={"y": y, "x": x},
        attrs={
            "range_resolution": res_range,
            "azimuth_resolution": res_azimuth,
            "range_axis": range_axis.tolist(),
            "azimuth_axis": azimuth_axis.tolist(),
        },
    )


@pytest.mark.parametrize("squint", [0.0, 7.1])
def test_slant_grid_separable_sinc(squint: float) -> None:
    ds, target = slant_image((71.37, 60.82), squint=squint)
    result = measure_impulse_response(ds, target, islr_extent="paper")
    json.dumps(result)  # plain JSON-serialisable types
    # Peak within 1 % of a cell (0.001 m) of the planted position: the 2-D quadratic refinement
    # on 32× samples is good to ~1e-4 cells.
    assert result["peak_offset_m"] < 0.01 * 0.1
    # Unit peak: the 2-D quadratic refinement on 32× samples and the interpolation leave ≲ 1e-4.
    assert result["peak_db"] == pytest.approx(0.0, abs=1e-3)
    # Sinc, so the continuous closed forms hold; the brief's tolerances are loose: the measured
    # deviations are ≲ 2e-5 cells and ≲ 2e-4 dB (the chip interpolation error is ~1e-5).
    for name in ("range", "azimuth"):
        cut = result[name]
        assert cut["irw_cells"] == pytest.approx(0.886, abs=0.002)
        assert cut["irw_m"] == pytest.approx(cut["irw_cells"] * 0.1, rel=1e-12)
        assert cut["pslr_db"] == pytest.approx(PSLR_RECT, abs=0.01)
        assert cut["islr_db"] == pytest.approx(ISLR_RECT["paper"], abs=0.01)
    # Separable 2-D ISLR in a ±5-cell box, closed form −7.5022 dB; the hard-edged box on the 32×
    # grid (no end corrections, unlike the 1-D trapezoid) is good to ~1e-3 dB.
    assert result["islr_2d_db"] == pytest.approx(SINC_ISLR_2D_PAPER, abs=0.005)


def test_slant_grid_extents() -> None:
    ds, target = slant_image((80.5, 63.91))
    # 16× per 0.5-cell pixel is 32 samples per cell, as 32× at one pixel per cell; it keeps the
    # test fast (the upsampled chip is 4× smaller).
    isce3 = measure_impulse_response(ds, target, islr_extent="isce3", upsample=16)
    # ±11 cells: closed form −10.113 dB; measured to ~1e-4 dB, 0.002 allows for the peak offset
    # rounding of the extent limits.
    assert isce3["range"]["islr_db"] == pytest.approx(sinc_islr_db(11), abs=0.002)
    assert isce3["azimuth"]["islr_db"] == pytest.approx(sinc_islr_db(11), abs=0.002)
    whole = measure_impulse_response(ds, target, islr_extent="chip", chip_cells=24, upsample=16)
    # Whole chip: the cut reaches ±(24 + up to half a pixel) cells from the peak; the sidelobe
    # power density there, ≈ 1/(2π²L²) per cell, makes that a ≤ 0.002 dB effect.
    assert whole["chip_cells"] == 24.0
    for name in ("range", "azimuth"):
        assert whole[name]["islr_db"] == pytest.approx(sinc_islr_db(24.25), abs=0.003)


@pytest.mark.parametrize("extent", ["inf", 7.5])
def test_slant_grid_large_chip(extent: str | float) -> None:
    # "inf" uses the whole of a ±64-cell chip: for a sinc that is the ±64-cell value,
    # −9.752 dB, 0.07 dB above the infinite one (the energy beyond ±L cells is 1/(π²L)).
    ds, target = slant_image((150.37, 140.82), shape=(300, 290))
    result = measure_impulse_response(ds, target, islr_extent=extent)
    if extent == "inf":
        expected = sinc_islr_db(64.25)
        assert result["chip_cells"] == 64.0
        assert result["upsample"] < 32  # reduced to bound the upsampled chip's memory
    else:
        expected = sinc_islr_db(extent)
    # IRW: even at the reduced factor (≥ 11 samples per pixel, 22 per cell) linear half-power
    # interpolation is good to ~2e-4 cells.
    assert result["range"]["irw_cells"] == pytest.approx(0.886, abs=0.002)
    assert result["range"]["islr_db"] == pytest.approx(expected, abs=0.003)
    assert result["islr_2d_db"] == pytest.approx(islr_2d_separable(expected, expected), abs=0.02)


def test_rotated_planar_grid() -> None:
    peak_yx = (0.013, 4.3071)
    ds = rotated_image(30.0, peak_yx, res_range=0.1, res_azimuth=0.15)
    target = [peak_yx[1], peak_yx[0], 1.5]
    result = measure_impulse_response(ds, target, islr_extent="paper")
    # A sinc, so the continuous closed forms hold. The cubic-spline cut through the ~30× chip
    # adds ≲ 1e-5 relative amplitude (measured: 1e-5 cells, 1e-4 dB); the brief's tolerances.
    assert result["peak_offset_m"] < 0.01 * 0.1
    for name in ("range", "azimuth"):
        assert result[name]["irw_cells"] == pytest.approx(0.886, abs=0.002)
        assert result[name]["pslr_db"] == pytest.approx(PSLR_RECT, abs=0.01)
        assert result[name]["islr_db"] == pytest.approx(ISLR_RECT["paper"], abs=0.01)
    # Different resolutions: the metre widths scale with each direction's cell.
    assert result["range"]["irw_m"] == pytest.approx(0.08859, abs=0.0002)
    assert result["azimuth"]["irw_m"] == pytest.approx(0.13288, abs=0.0003)
    # 2-D box and main lobe in the rotated frame: as for the slant grid.
    assert result["islr_2d_db"] == pytest.approx(SINC_ISLR_2D_PAPER, abs=0.005)


def test_image_errors() -> None:
    ds, target = slant_image((71.37, 60.82))
    with pytest.raises(ValueError, match="outside the image"):
        measure_impulse_response(ds, [target[0], target[1] + 10.0, 0.0])
    with pytest.raises(ValueError, match="too close to the image edge"):
        measure_impulse_response(ds, [ds.azimuth.values[3], target[1], 0.0])
    with pytest.raises(ValueError, match="islr_extent") as info:
        measure_impulse_response(ds, target, islr_extent="everything")
    for word in ("'paper'", "'isce3'", "'chip'", "'inf'", "'everything'"):
        assert word in str(info.value)
    with pytest.raises(ValueError, match="chip_cells"):
        measure_impulse_response(ds, target, islr_extent="isce3", chip_cells=8)


def test_critically_sampled_image_warns() -> None:
    # Full-band spectrum (one sample per cell): the sub-sample peak cannot be interpolated
    # unambiguously, which the function must say.
    ds, target = slant_image((71.37, 60.82))
    full = ds.copy()
    amp = np.outer(dirichlet(160, 160, 71.37), dirichlet(128, 128, 60.82))
    full["image"] = (("azimuth", "range"), amp)
    assert max(band_fill_db(ds["image"].values[40:105, 28:93])) < -10.0
    with pytest.warns(RuntimeWarning, match="fills the band"):
        measure_impulse_response(full, target)
