"""Layover and shadow masks from the scene's geometry (mitsar.scene.masks) against closed forms.

Geometry of every test: a straight level track along x at y = 0, height H = 4.5 m, looking left
(+y) at the paper's 55.7 deg off nadir (boresight on the floor at Y = H tan 55.7 deg = 6.6 m);
the image is a floor grid of 1 cm pixels along y (ground range) and three columns along x, made
directly (the masks read the image product's geometry only: positions, aperture, attributes).
"""

import numpy as np
import pytest
import xarray as xr

import mitsar
from mitsar.errors import ParameterError
from mitsar.products.raw import channel_variables, product_attrs
from mitsar.scene.masks import layover_shadow_masks, stretch_count

H = 4.5
LOOK = mitsar.Look(55.7)
RADAR = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.05)])
DELTA = RADAR.range_resolution / 2
SPACING = 0.01  # pixel spacing along y [m]
Y = np.arange(5.0, 9.5, SPACING)
X = np.array([14.8, 15.0, 15.2])

FLOOR = """<shape type="rectangle" id="floor"><transform name="to_world"><scale x="5" y="6"/>
<translate x="15" y="8" z="0"/></transform></shape>"""
WALL = """<shape type="rectangle" id="wall"><transform name="to_world">
<scale x="1" y="{half}"/><rotate x="1" angle="90"/><translate x="15" y="{y0}" z="{half}"/>
</transform></shape>"""
BOX = """<shape type="cube" id="box"><transform name="to_world">
<scale x="1" y="{depth_half}" z="{half}"/><translate x="15" y="{centre}" z="{half}"/>
</transform></shape>"""


def _scene(*shapes):
    return '<scene version="3.0.0">' + "".join(shapes) + "</scene>"


def _image():
    """A multi-channel image product's geometry: pixels on the floor, the aperture along x."""
    aperture = np.stack([np.arange(13.0, 17.0, 0.002), np.zeros(2000), np.full(2000, H)], -1)
    position = np.stack(np.broadcast_arrays(X[None, :], Y[:, None], 0.0), -1)
    return xr.Dataset(
        {"position": (("v", "u", "xyz"), position),
         "aperture_position": (("aperture", "xyz"), aperture),
         "aperture_attitude": (("aperture", "angle"), np.zeros_like(aperture)),
         **channel_variables(RADAR)},
        coords={"v": Y, "u": X},
        attrs=product_attrs("image", RADAR, LOOK, rvp=True))


def _masks(tmp_path, xml, **kwargs):
    path = tmp_path / "scene.xml"
    path.write_text(xml)
    return layover_shadow_masks(path, _image(), **kwargs)


def _ground(r):
    """Floor distance from the track's ground line of the floor point at slant range r."""
    return np.sqrt(r ** 2 - H ** 2)


def _band(values):
    """First and last y of the pixels where ``values`` (along y) is True, and their count."""
    where = Y[np.asarray(values, bool)]
    return (where.min(), where.max(), where.size) if where.size else (np.nan, np.nan, 0)


def test_flat_floor_has_no_shadow_and_no_layover(tmp_path):
    """A floor only: every pixel sees one surface (visible_surfaces == 1 everywhere)."""
    masks = _masks(tmp_path, _scene(FLOOR))
    assert masks["visible_surfaces"].dims == ("v", "u")
    assert np.all(masks["visible_surfaces"].values == 1)
    assert not masks["mask"].values.any()
    assert masks.attrs["range_window"] == pytest.approx(DELTA)


@pytest.mark.parametrize("window", [None, 1e-3])
def test_wall_shadow_and_layover_have_their_closed_form_lengths(tmp_path, window):
    """A thin wall of height h = 0.3 m facing the radar at ground distance Y0 = 6.6 m.

    Closed form (antenna at height H, floor pixel of slant range r, window delta):
    the wall spans ranges [r_t, r_b], r_b = sqrt(Y0^2 + H^2) (its foot, = the floor at Y0),
    r_t = sqrt(Y0^2 + (H - h)^2) (its top); the floor behind is visible again from
    r_s = r_t H / (H - h) (the ray over the top meets the floor at Y0 H / (H - h)). A floor
    pixel sees the floor in front when r - delta <= r_b, the wall when its window meets
    [r_t, r_b], the floor behind when r + delta >= r_s. So layover (floor and wall) for r in
    [r_t - delta, r_b + delta] and shadow for r in (r_b + delta, r_s - delta); on the ground
    (Y(r) = sqrt(r^2 - H^2)) the layover band is h H / Y0 ~ h cot(theta_i) long plus
    2 delta / sin(theta_i), the shadow Y0 h / (H - h) ~ h tan(theta_i) less 2 delta /
    sin(theta_i) (theta_i ~ 55.7 deg the incidence). With a 1 mm window these are the bare
    h cot(theta_i) and h tan(theta_i). Asserted: both band edges within one pixel (1 cm).
    Measured (first and last masked pixel; delta = 5 cm, then 1 mm): layover [6.34, 6.66] m
    vs [6.338, 6.660] m and [6.40, 6.60] vs [6.398, 6.601]; shadow [6.67, 7.01] vs
    [6.660, 7.012] and [6.61, 7.07] vs [6.601, 7.070]: every edge on the first 1 cm pixel
    inside the exact band (edges bisected to 1 mrad / 2^8 in elevation).
    """
    h, y0 = 0.3, 6.6
    kwargs = {} if window is None else {"range_resolution": 2 * window}
    masks = _masks(tmp_path, _scene(FLOOR, WALL.format(half=h / 2, y0=y0)), **kwargs)
    delta = DELTA if window is None else window
    r_b, r_t = np.hypot(y0, H), np.hypot(y0, H - h)
    r_s = r_t * H / (H - h)
    layover = (_ground(r_t - delta), _ground(r_b + delta))
    shadow = (_ground(r_b + delta), _ground(r_s - delta))
    if window is not None:  # the bare closed forms
        assert layover[1] - layover[0] == pytest.approx(h * H / y0, rel=0.05)
        assert shadow[1] - shadow[0] == pytest.approx(y0 * h / (H - h), abs=3e-3)
    for column in range(len(X)):
        lay = _band(masks["layover"].values[:, column])
        sha = _band(masks["shadow"].values[:, column])
        assert lay[0] == pytest.approx(layover[0], abs=SPACING), (lay, layover)
        assert lay[1] == pytest.approx(layover[1], abs=SPACING), (lay, layover)
        assert sha[0] == pytest.approx(shadow[0], abs=SPACING), (sha, shadow)
        assert sha[1] == pytest.approx(shadow[1], abs=SPACING), (sha, shadow)
        assert lay[2] == pytest.approx((layover[1] - layover[0]) / SPACING, abs=1.5)
        assert sha[2] == pytest.approx((shadow[1] - shadow[0]) / SPACING, abs=1.5)
    assert not (masks["shadow"] & masks["layover"]).values.any()
    assert np.array_equal(masks["mask"], masks["shadow"] | masks["layover"])


def test_box_masks_where_the_geometry_says(tmp_path):
    """A box of height h = 0.2 m, front face at Y0 = 6.6 m, back at Y1 = 8.2 m (the room test's
    box in this geometry). Closed form as for the wall (test above), with the top between:
    the front face spans ranges [r_t, r_b], the top [r_t, r_e], r_e = sqrt(Y1^2 + (H - h)^2)
    its far edge; the floor behind is visible from r_s = r_e H / (H - h). Layover: floor pixels
    of r in [r_t - delta, r_b + delta] (floor, front face and top: the top and front face
    map onto floor pixels h H / Y0 ~ 0.14 m nearer than the box); one surface (the top) over
    (r_b + delta, r_e + delta]: those pixels are clean, though the floor at them is hidden;
    shadow over (r_e + delta, r_s - delta): on the ground h tan(theta_i) (behind the box) plus
    h H / Y1 (the far top edge's own layover shift) less 2 delta / sin(theta_i).
    Measured (first and last masked pixel): layover [6.41, 6.66] m vs [6.404, 6.660] m, shadow
    [8.15, 8.52] m vs [8.149, 8.525] m; the top's pixels between see one surface.
    """
    h, y0, y1 = 0.2, 6.6, 8.2
    masks = _masks(tmp_path, _scene(FLOOR, BOX.format(depth_half=(y1 - y0) / 2,
                                                       centre=(y0 + y1) / 2, half=h / 2)))
    r_b, r_t, r_e = np.hypot(y0, H), np.hypot(y0, H - h), np.hypot(y1, H - h)
    r_s = r_e * H / (H - h)
    layover = (_ground(r_t - DELTA), _ground(r_b + DELTA))
    shadow = (_ground(r_e + DELTA), _ground(r_s - DELTA))
    assert layover[1] - layover[0] == pytest.approx(h * H / y0 + 2 * DELTA / np.sin(
        np.arctan(y0 / H)), rel=0.05)
    for column in range(len(X)):
        lay = _band(masks["layover"].values[:, column])
        sha = _band(masks["shadow"].values[:, column])
        for measured, exact in ((lay, layover), (sha, shadow)):
            assert measured[0] == pytest.approx(exact[0], abs=SPACING), (measured, exact)
            assert measured[1] == pytest.approx(exact[1], abs=SPACING), (measured, exact)
        top = (Y > layover[1] + SPACING) & (Y < shadow[0] - SPACING)
        assert np.all(masks["visible_surfaces"].values[top, column] == 1)
        outside = (Y < layover[0] - SPACING) | (Y > shadow[1] + SPACING)
        assert not masks["mask"].values[outside, column].any()


def test_stretches_are_counted_across_sampling_gaps():
    """A continuous surface whose range jumps over the window between two rays still counts
    (the range is interpolated along the segment); an occlusion jump starts a new stretch."""
    distance = np.array([[1.0, 2.0, 3.0, 2.05, 1.0]])
    points = np.stack([np.zeros(5), np.zeros(5), distance[0]], -1)[None]
    points[0, 3:, 0] = 1.0           # rays 3-4 on another surface, off the first one's plane
    normals = np.tile([1.0, 0.0, 0.0], (1, 5, 1))
    assert stretch_count(distance, points, normals, np.array([2.5]), 0.01)[0] == 1
    assert stretch_count(distance, points, normals, np.array([2.03]), 0.05)[0] == 2
    assert stretch_count(distance, points, normals, np.array([5.0]), 0.05)[0] == 0


def test_masks_refuse_an_image_without_its_geometry():
    """An image without the aperture is refused, naming the missing variable."""
    with pytest.raises(ParameterError, match="aperture_position"):
        layover_shadow_masks("dihedral", _image().drop_vars("aperture_position"))


def test_interferometry_step_leaves_out_and_keeps_the_scene_masks(tmp_path):
    """The interferogram step of ``mitsar run`` with a scene: the masked pixels have no height
    (left out through ``interferogram(mask=...)``), the masks are variables of the product on
    the image's full grid, and they survive interferogram.nc."""
    from mitsar.experiment.interferometry import (
        InterferometryOptions,
        interferometry_summary,
        run_interferometry,
        write_interferometry,
    )
    from mitsar.io import load

    image = _image()
    image["image"] = (("channel", "v", "u"), np.ones((2, Y.size, X.size), complex))
    path = tmp_path / "wall.xml"
    path.write_text(_scene(FLOOR, WALL.format(half=0.15, y0=6.6)))
    options = InterferometryOptions(looks=(1, 1), unwrap=False)
    result = run_interferometry(image, options, scene=str(path), quiet=True)
    ifg = result.interferogram
    mask = ifg["layover_shadow_mask"].values
    assert ifg["layover_shadow_mask"].dims == ("image_v", "image_u")
    assert 0 < mask.sum() < mask.size
    assert np.all(np.isnan(ifg["height"].values[mask]))
    assert np.all(np.isfinite(ifg["height"].values[~mask]))
    summary = interferometry_summary(result)
    assert summary["shadow_fraction"] == pytest.approx(ifg["shadow"].values.mean())
    paths = write_interferometry(tmp_path / "out", result)
    saved = load(paths["interferogram"])
    assert np.array_equal(saved["layover_shadow_mask"].values.astype(bool), mask)
    assert saved.attrs["mask_range_window"] == pytest.approx(DELTA)
