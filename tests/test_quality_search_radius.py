"""The peak search radius of :func:`mitsar.quality.impulse.measure_impulse_response`
(docs/reliability.md §4, the fuzz campaign's VAGUE case).

A radius of 1e300 m overflowed the search window's pixel count and its squared distances, the
window came out empty or inverted and the error blamed ``target`` ("its peak is on the border
pixel [0, 0]"). A radius is now a length like any other (within ``checks.MAX_LENGTH``, refused
naming ``search_radius_m`` beyond), and a radius past the image's diagonal searches the whole
image, as it says.
"""

from __future__ import annotations

import pytest
from test_quality import slant_image  # tests/ is on sys.path (no __init__.py)

from mitsar.checks import MAX_LENGTH
from mitsar.errors import ParameterError
from mitsar.quality.geometry import read_geometry
from mitsar.quality.impulse import measure_impulse_response
from mitsar.quality.peak import peak_pixel


@pytest.mark.parametrize("radius", [1e300, 2 * MAX_LENGTH])
def test_a_radius_beyond_any_scene_is_refused_naming_it(radius: float) -> None:
    ds, target = slant_image((71.37, 60.82))
    with pytest.raises(ParameterError, match="search_radius_m") as info:
        measure_impulse_response(ds, target, search_radius_m=radius)
    assert "'target'" not in str(info.value)
    assert f"{MAX_LENGTH:g}" in str(info.value)


def test_a_radius_past_the_image_searches_the_whole_image() -> None:
    """The planted peak (pixel 71.37, 60.82 of 160 x 128, 0.05 m pixels: a 10.2 m diagonal)
    is found with radii of 1 km and 1e300 m as with one just past the diagonal, at the same
    pixel, and the measurement reports the radius asked for."""
    ds, target = slant_image((71.37, 60.82))
    geometry = read_geometry(ds, "response")
    index = [71.37, 60.82]
    assert peak_pixel(geometry, index, 1.0e3).tolist() == [71, 61]
    assert peak_pixel(geometry, index, 1.0e300).tolist() == [71, 61]  # no overflow
    assert peak_pixel(geometry, index, 10.5).tolist() == [71, 61]
    result = measure_impulse_response(ds, target, search_radius_m=MAX_LENGTH, upsample=8)
    assert result["search_radius_m"] == MAX_LENGTH
    assert result["peak_offset_m"] < 0.01 * 0.1  # within 1 % of a cell, as test_quality's
