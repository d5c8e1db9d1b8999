"""3-D focusing from several passes (issue 23, item 2): VolumeGrid, tomographic back-projection,
elevation resolution predicted and measured.

Closed forms (mitsar.model.geometry.tomography, Reigber & Moreira 2000, IEEE TGRS 38(5)): a
stack of N passes spaced d across the line of sight at range R samples an elevation aperture
L_perp = N d; the coherent sum of the passes' images has the elevation response
AF(s) = (1/N) sum_n exp(-j 4 pi b_n s / (lambda R)) (a Dirichlet kernel), first null at
rho_e = lambda R / (2 L_perp), -3 dB width 0.8919 rho_e for N = 8 (0.8859 rho_e for a continuous
aperture), grating lobes every lambda R / (2 d).

Set-up: the default radar (94 GHz, lambda = 3.19 mm, 0.1 m range cells), eight straight tracks
along x at heights 1.0 +- 3.5 cm (d = 1 cm), the antenna looking horizontally (off-nadir 90 deg)
at targets 2 m away: the line of sight is +y, the elevation axis is z, so a cut along the
volume's z through the peak is the elevation cut. rho_e = 39.9 mm, predicted IRW 35.6 mm,
grating lobes every 0.32 m (the volume spans +-0.12 m: unambiguous).
"""

from __future__ import annotations

import numpy as np
import pytest

import mitsar
from mitsar.budget import MemoryBudgetError
from mitsar.errors import ParameterError
from mitsar.focus.grid import from_dict
from mitsar.model.geometry.tomography import (
    RECT_IRW_CELLS,
    effective_aperture,
    elevation_ambiguity,
    elevation_irw,
    elevation_resolution,
    perpendicular_baselines,
)
from mitsar.products.image import validate_image
from mitsar.quality.cuts import irw
from mitsar.quality.volume import dip_db, elevation_cut, measure_elevation, resolved

RADAR = mitsar.Radar()
LOOK = mitsar.Look(90.0)
PASSES, SPACING, RANGE, HEIGHT = 8, 0.01, 2.0, 1.0
HEIGHTS = HEIGHT + (np.arange(PASSES) - (PASSES - 1) / 2) * SPACING
TARGET = np.array([15.0, 1.4 + RANGE, HEIGHT])
RHO = RADAR.wavelength * RANGE / (2 * PASSES * SPACING)  # eq. T2 with L_perp = N d
GRID = mitsar.grid.VolumeGrid(x=[14.98, 15.02, 0.004], y=[3.3, 3.5, 0.02],
                              z=[HEIGHT - 0.12, HEIGHT + 0.12, 0.002])


def _passes(targets, heights=HEIGHTS, radar=RADAR):
    return [mitsar.simulate_point_targets(
        radar, mitsar.Trajectory.linear([14.7, 1.4, h], [0.5, 0.0, 0.0], 1.2), LOOK,
        [mitsar.PointTarget(t) for t in targets], normalized=True) for h in heights]


@pytest.fixture(scope="module")
def one_target():
    return _passes([TARGET])


@pytest.fixture(scope="module")
def volume(one_target):
    return mitsar.focus(one_target, "bpa", GRID)


def _pair(separation):
    """Two equal targets separated by ``separation`` along z (elevation), the upper one
    lambda/8 further in range (0.4 mm, 0.004 range cells): a quarter-wave two-way phase, so
    their responses add in power (module docstring of mitsar.quality.volume)."""
    offset = np.array([0.0, RADAR.wavelength / 8, 0.0])
    return _passes([TARGET - [0, 0, separation / 2], TARGET + [0, 0, separation / 2] + offset])


def test_closed_forms_of_the_elevation_resolution():
    assert elevation_resolution(0.004, 2.0, 0.08) == pytest.approx(0.05)
    assert elevation_ambiguity(0.004, 2.0, 0.01) == pytest.approx(0.4)
    uniform = (np.arange(8) - 3.5) * 0.01
    assert effective_aperture(uniform) == pytest.approx(0.08)
    rho = elevation_resolution(0.004, 2.0, 0.08)
    assert elevation_irw(uniform, 0.004, 2.0) / rho == pytest.approx(0.8919, abs=2e-4)
    dense = (np.arange(256) - 127.5) * 0.08 / 256
    assert elevation_irw(dense, 0.004, 2.0) / rho == pytest.approx(RECT_IRW_CELLS, abs=2e-4)
    positions = np.c_[np.zeros(3), np.zeros(3), [0.9, 1.0, 1.1]]
    baselines, axis, slant = perpendicular_baselines(positions, [0, 2, 1.0], [1, 0, 0])
    assert np.allclose(axis, [0, 0, 1]) and slant == pytest.approx(2.0)
    assert np.allclose(baselines, [-0.1, 0.0, 0.1])
    for bad in ((0.004, 0.0, 0.08), (float("nan"), 2.0, 0.08), (0.004, 2.0, -1.0)):
        with pytest.raises(ParameterError):
            elevation_resolution(*bad)
    with pytest.raises(ParameterError, match="baselines"):
        effective_aperture([0.1, 0.1])


def test_volume_grid_voxels_dims_and_memory():
    grid = mitsar.grid.VolumeGrid(x=[0.0, 0.2, 0.1], y=[1.0, 1.1, 0.1], z=[-1.0, 1.0, 0.5])
    raw = _passes([TARGET], heights=[HEIGHT])[0]
    layout = grid.resolve(raw, RADAR, 0.01)
    assert layout["dims"] == ("z", "y", "x") and layout["position"].shape == (5, 2, 3, 3)
    assert np.allclose(layout["position"][4, 1, 2], [0.2, 1.1, 1.0])
    assert np.allclose(layout["position"][:, 0, 0, 2], layout["coords"]["z"])
    assert from_dict({"kind": "volume", "x": [0, 1, 0.5], "y": [0, 1, 0.5],
                      "z": [0, 1, 0.5]}) == from_dict({"type": "volume", "x": [0, 1, 0.5],
                                                       "y": [0, 1, 0.5], "z": [0, 1, 0.5]})
    with pytest.raises(ParameterError, match="'z'"):
        mitsar.grid.VolumeGrid(x=[0, 1, 0.1], y=[0, 1, 0.1], z=[1, 0, 0.1]).axes()
    with pytest.raises(MemoryBudgetError, match="VolumeGrid"):  # before any voxel is made
        mitsar.grid.VolumeGrid(x=[0, 10, 1e-3], y=[0, 10, 1e-3], z=[0, 10, 1e-3]).axes()


def test_point_target_elevation_irw_within_5_percent(volume):
    """(a) The 3-D response of one point: its elevation IRW is the array factor's (0.8919
    rho_e for 8 passes, exact) and within 5 % of 0.8859 lambda R / (2 N d) (measured: 35.68 mm
    against 35.56 mm and 35.32 mm)."""
    validate_image(volume)
    with pytest.raises(ParameterError, match="coverage"):
        validate_image(volume.drop_vars("coverage"))
    assert volume["image"].dims == ("z", "y", "x") and volume.attrs["passes"] == PASSES
    assert volume.attrs["elevation_resolution"] == pytest.approx(RHO, rel=1e-4)
    assert volume.attrs["perpendicular_aperture"] == pytest.approx(PASSES * SPACING, rel=1e-6)
    assert np.allclose(volume["pass_baseline"].values, HEIGHTS - HEIGHT, atol=1e-6)
    measured = measure_elevation(volume, TARGET)
    assert measured["dim"] == "z"
    assert np.allclose(measured["position"], TARGET, atol=1e-9)  # peak on the target's voxel
    assert measured["irw"] == pytest.approx(volume.attrs["elevation_irw_predicted"], rel=0.05)
    assert measured["irw"] == pytest.approx(RECT_IRW_CELLS * RHO, rel=0.05)
    assert abs(measured["ratio"] - 1) < 0.01  # measured: 0.3 %


@pytest.mark.parametrize(("factor", "apart"), [(0.8, False), (1.5, True)])
def test_two_targets_in_elevation_resolved_at_1_5_not_at_0_8(factor, apart):
    """(b) Two equal targets separated only in elevation by 0.8 rho_e show one peak (no dip);
    at 1.5 rho_e two, with a dip >= 3 dB (measured 0 and 7.4 dB; closed form 0 and 7.5 dB)."""
    image = mitsar.focus(_pair(factor * RHO), "bpa", GRID)
    cut = elevation_cut(image, TARGET)["cut"]
    assert resolved(cut) is apart
    if not apart:
        assert dip_db(cut) == 0.0


def test_volume_slice_is_the_plane_image(one_target, volume):
    """(c) A slice z = z_k of a volume is the PlaneGrid BPA image at z_k (the same kernel on the
    same positions): one pass bit for bit; several passes combined, to float rounding."""
    k = 60 + 7
    z = float(GRID.axes()[2][k])
    plane = mitsar.grid.PlaneGrid(origin=[0, 0, z], axis_u=[1, 0, 0], axis_v=[0, 1, 0],
                                  u=GRID.x, v=GRID.y)
    single_volume = mitsar.focus(one_target[0], "bpa", GRID)
    single_plane = mitsar.focus(one_target[0], "bpa", plane)
    assert single_plane["image"].dims == ("v", "u")
    assert np.array_equal(single_volume["image"].values[k], single_plane["image"].values)
    assert np.array_equal(single_volume["coverage"].values[k], single_plane["coverage"].values)
    stacked_plane = mitsar.focus(one_target, "bpa", plane)
    validate_image(stacked_plane)
    scale = np.abs(volume["image"].values).max()
    assert np.abs(volume["image"].values[k] - stacked_plane["image"].values).max() \
        <= 1e-12 * scale


def test_incoherent_sum_has_no_elevation_resolution(one_target, volume):
    """(d) Coherent: the elevation IRW (above). Incoherent (root mean square of the passes):
    no elevation resolution, the elevation cut stays within 0.1 dB over +-0.12 m = 6.7 IRW,
    and two targets 1.5 rho_e apart are not resolved."""
    incoherent = mitsar.focus(one_target, "bpa", GRID, combine="incoherent")
    validate_image(incoherent)
    assert incoherent.attrs["pass_combine"] == "incoherent"
    assert not np.iscomplexobj(incoherent["image"].values)
    cut = np.abs(elevation_cut(incoherent, TARGET)["cut"]) ** 2
    assert 10 * np.log10(cut.max() / cut.min()) < 0.1
    coherent_cut = np.abs(elevation_cut(volume, TARGET)["cut"]) ** 2
    assert 10 * np.log10(coherent_cut.max() / coherent_cut.min()) > 10
    # the peaks agree: the coherent sum of in-phase passes equals their rms at the target
    assert np.sqrt(cut.max()) == pytest.approx(np.sqrt(coherent_cut.max()), rel=0.01)
    pair = mitsar.focus(_pair(1.5 * RHO), "bpa", GRID, combine="incoherent")
    assert not resolved(elevation_cut(pair, TARGET)["cut"])


def test_channels_of_a_pass_are_combined_coherently():
    """Two receivers 4 cm apart vertically: the single-raw volume keeps the channel dim; a list
    of passes combines channels (their midpoints add to the elevation aperture)."""
    radar = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.04)])
    raws = _passes([TARGET], heights=HEIGHTS[::4], radar=radar)
    small = mitsar.grid.VolumeGrid(x=[14.996, 15.004, 0.004], y=[3.38, 3.42, 0.02],
                                   z=[HEIGHT - 0.04, HEIGHT + 0.04, 0.02])
    alone = mitsar.focus(raws[0], "bpa", small)
    assert alone["image"].dims == ("channel", "z", "y", "x")
    combined = mitsar.focus(raws, "bpa", small)
    validate_image(combined)
    assert combined["image"].dims == ("z", "y", "x") and combined.attrs["pass_channels"] == [2, 2]
    # phase centres at the transmitter-receiver midpoints, 0 and +0.02 m above each pass of two
    # 0.04 m apart: four centres spaced 0.02 m, an aperture of 4 x 0.02 m
    assert combined.attrs["perpendicular_aperture"] == pytest.approx(0.08, rel=1e-4)
    expected = (alone["image"].values.mean(axis=0)
                + mitsar.focus(raws[1], "bpa", small)["image"].values.mean(axis=0)) / 2
    assert np.allclose(combined["image"].values, expected, rtol=0, atol=1e-12)


def test_ffbp_focuses_a_volume_slice_by_slice(one_target):
    pytest.importorskip("drjit")
    small = mitsar.grid.VolumeGrid(x=[14.98, 15.02, 0.004], y=[3.3, 3.5, 0.02],
                                   z=[HEIGHT - 0.02, HEIGHT + 0.02, 0.02])
    try:
        fast = mitsar.focus(one_target[:2], "ffbp", small)
    except ParameterError as error:  # no LLVM / CUDA backend here (docs/gpu.md)
        pytest.skip(str(error))
    exact = mitsar.focus(one_target[:2], "bpa", small)
    assert fast["image"].dims == ("z", "y", "x") and fast.attrs["ffbp_volume_slices"] == 3
    error = np.abs(fast["image"].values - exact["image"].values).max()
    assert error < 0.01 * np.abs(exact["image"].values).max()  # measured 0.4 %


def test_refusals(one_target):
    raw = one_target[0]
    with pytest.raises(ParameterError, match="grid"):
        mitsar.focus(one_target, "bpa")  # a slant grid belongs to one track
    with pytest.raises(ParameterError, match="combine"):
        mitsar.focus(one_target, "bpa", GRID, combine="sum")
    with pytest.raises(ParameterError, match="combine"):
        mitsar.focus(raw, "bpa", GRID, combine="incoherent")
    with pytest.raises(ParameterError, match="raw"):
        mitsar.focus([], "bpa", GRID)
    with pytest.raises(ParameterError, match=r"raw\[1\]"):
        mitsar.focus([raw, "raw"], "bpa", GRID)
    with pytest.raises(ParameterError, match="algorithm"):
        mitsar.focus(raw, "rda", GRID)
    with pytest.raises(ParameterError, match="autofocus"):
        mitsar.focus(raw, "bpa", GRID, autofocus="pga")
    with pytest.raises(ParameterError, match="autofocus"):
        mitsar.focus(one_target[:2], "bpa", {"kind": "volume", "x": GRID.x, "y": GRID.y,
                                             "z": GRID.z}, autofocus="pga")
    other = _passes([TARGET], heights=[HEIGHT], radar=mitsar.Radar(carrier_frequency=77e9))[0]
    with pytest.raises(ParameterError, match="carrier"):
        mitsar.focus([raw, other], "bpa", GRID)


def test_tilted_line_of_sight_projects_the_stack():
    """A vertical stack looking down at 43 deg: the aperture across the line of sight is the
    stack's N d times |e_z| (e normal to the track and the line of sight), and the response
    along e, focused on a line of points through the target, has the predicted IRW (measured
    44.65 mm against 44.54 mm)."""
    spacing, height, target = 0.012, 1.5, np.array([15.0, 3.0, 0.0])
    heights = height + (np.arange(PASSES) - (PASSES - 1) / 2) * spacing
    look = mitsar.Look(float(np.degrees(np.arctan2(1.6, 1.5))))
    raws = [mitsar.simulate_point_targets(
        RADAR, mitsar.Trajectory.linear([14.7, 1.4, h], [0.5, 0.0, 0.0], 1.2), look,
        [mitsar.PointTarget(target)], normalized=True) for h in heights]
    sight = target - [15.0, 1.4, height]
    axis = np.cross([1.0, 0.0, 0.0], sight / np.linalg.norm(sight))
    offsets = np.arange(-0.1, 0.1 + 1e-9, 0.001)
    line = mitsar.focus(raws, "bpa", mitsar.grid.PointsGrid(target + offsets[:, None] * axis))
    assert np.allclose(line.attrs["elevation_axis"], axis, atol=1e-6)
    assert line.attrs["perpendicular_aperture"] == pytest.approx(
        PASSES * spacing * axis[2], rel=1e-6)
    measured = irw(line["image"].values[:, 0]) * 0.001
    assert measured == pytest.approx(line.attrs["elevation_irw_predicted"], rel=0.02)
