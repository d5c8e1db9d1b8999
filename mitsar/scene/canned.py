"""The bundled Mitsuba scenes of mitsar: ``scenes/`` at the top of the checkout, installed as the
data package ``mitsar._scenes`` and found with :mod:`importlib.resources` (in an installed wheel,
and in a checkout through the editable install's finder; docs/decisions.md, "Layout").

================== =========================================================================
name               content
================== =========================================================================
control_volume     the paper's 30 × 10 × 6 m room (Table 3): concrete floor, ceiling, 4 walls
point_target       one point target (RCS 1 m²) at [15, 8, 0.03] m above an absorbing floor
dihedral           floor (x-y) and the wall y = 10 m (x-z): the dihedral edge of §4.3
trihedral          floor, wall y = 10 m and wall x = 0 (y-z): the trihedral corner of §4.3
cross_section_2d   the room's y-z cross-section extruded along x (floor, ceiling, walls
                   y = 0 and y = 10 m; no end walls) for the 2D cases of §4.2 (Figs. 10-11)
box_obstacle       concrete floor and a 1 × 0.5 × 2 m concrete cabinet (PLY mesh)
walking_person     floor, back wall with a 1 m² reflector, and a 0.5 × 0.3 × 1.8 m box walking
                   along x at ``speed`` (1 m/s) through the line of sight (a moving shape)
sionna_room        an 8 × 5 × 3 m room written in Sionna RT's dialect (``itu-radio-material``
                   concrete walls and ceiling board, a metal PLY cabinet, a ``radio-material``
                   glass window) with a point target: the worked example of docs/scenes.md
================== =========================================================================

Walls are one rectangle each with the normal pointing into the room. Every scene declares
``<default>`` parameters (e.g. ``material``; ``rcs`` and ``scattering`` for ``sionna_room``)
that :func:`mitsar.scene.load_scene` accepts as keywords. No scene names an integrator or
sensor; the radar integrator is chosen in Python. Meshes are in ``meshes/`` beside the XML.
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path

from mitsar.errors import MitsarError, ParameterError

__all__ = ["PACKAGE", "SCENE_DIR", "SIONNA_ROOM", "names", "path"]

PACKAGE = "mitsar._scenes"
"""The data package of the scenes (pyproject.toml's package-dir maps it to ``scenes/``)."""


def _scene_dir() -> Path:
    """The folder of :data:`PACKAGE` on disk; a source tree on ``PYTHONPATH`` that was never
    installed has no ``mitsar._scenes``, and its ``scenes/`` beside the package is taken."""
    try:
        folder = importlib.resources.files(PACKAGE)
    except ModuleNotFoundError:
        folder = None
    if isinstance(folder, Path) and folder.is_dir():
        return folder
    source = Path(__file__).resolve().parents[2] / "scenes"
    if source.is_dir():
        return source
    raise MitsarError(f"mitsar's bundled scenes not found: no package {PACKAGE} and no "
                      f"{source} (reinstall mitsar: pip install mitsar, or pip install -e . in "
                      "a checkout)")


SCENE_DIR = _scene_dir()
"""Directory holding the XML files (``meshes/`` beside them)."""

SIONNA_ROOM = SCENE_DIR / "sionna_room.xml"
"""The Sionna-dialect example room, also loadable by name as ``"sionna_room"`` (parameters
``rcs``, ``scattering``; docs/scenes.md)."""


def names() -> list[str]:
    """Names of the bundled scenes (XML file stems), sorted."""
    return sorted(p.stem for p in SCENE_DIR.glob("*.xml"))


def path(name: str) -> Path:
    """Path of a bundled scene's XML file.

    Parameters
    ----------
    name : str
        Scene name, with or without ``.xml`` (see :func:`names`).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ParameterError
        For an unknown name, listing the available ones.
    """
    stem = name[:-4] if isinstance(name, str) and name.endswith(".xml") else name
    if not isinstance(stem, str) or stem not in names():
        raise ParameterError("mitsar.scene.canned.path", "name", f"one of {names()}", name)
    return SCENE_DIR / f"{stem}.xml"
