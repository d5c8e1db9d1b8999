"""One typed trace request: every option of a ray-traced acquisition, in one Mitsuba-free type.

:class:`TraceOptions` is filled by three sources, merged once in this order (later wins):

1. the defaults of this module (:data:`DEFAULTS`);
2. the scene's ``<integrator type="radar">`` (XML parameters, :data:`XML_PARAMETERS`);
3. ``options=`` of :func:`mitsar.trace` / :func:`mitsar.simulate_scene`, which the
   experiment's TOML ``[simulation]`` table fills
   (:func:`mitsar.experiment.parsers.parse_simulation`);
4. keyword arguments of those functions (``trace(..., max_depth=3)``), shorthand for
   ``options.replace(max_depth=3)``.

A field left ``None`` is "not set here": the layer below decides. After :meth:`TraceOptions.resolve`
every field is set, except three whose ``None`` is itself a value: ``scatterer_density``
(then ``scatterers_per_cell`` per resolution cell), ``plane_normal`` (3-D mode) and ``orders``
(all path orders). The seed has one owner, :attr:`TraceOptions.seed`: the surface scatterers,
the speckle, the analytic targets added on top and the thermal noise all draw from it.

Nothing here imports Mitsuba or Dr.Jit, so a request is built and checked before a variant is
set (docs/integrator.md §"Parameters").
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from mitsar import checks
from mitsar.errors import ParameterError
from mitsar.model import histogram as hg
from mitsar.model.geometry.attitude import Look
from mitsar.model.multipath import CAPTURE_KINDS
from mitsar.model.radar import Radar

__all__ = ["AZIMUTH_CELL", "DEFAULTS", "DEFAULT_VISIBILITY_FEATURE", "XML_PARAMETERS",
           "TraceOptions"]

MAX_LANES = 2**26
"""Upper bound on lanes per kernel launch (Dr.Jit wavefront size; docs/design.md §7)."""

DEFAULT_CHUNK_LANES = 2**24
"""Default lanes (scatterer x sweep pairs) per kernel launch."""

MAX_DEPTH = 8
"""Largest ``max_depth`` (hits per ray; up to 7 reflections)."""

MULTIPATH_CHUNK_LANES = 2**20
"""Ray x sweep lanes per multipath launch (each lane holds ~40 floats of state)."""

DEFAULT_RAYS = 4096
"""Default number of multipath rays per sweep."""

AZIMUTH_CELL = 0.10
"""Azimuth size of the resolution cell for ``scatterers_per_cell`` [m] (paper Table 1)."""

DEFAULT_VISIBILITY_FEATURE = 0.03
"""Default smallest occluder (or gap) width that shadow-ray reuse across sweeps resolves [m]:
~10 wavelengths at 94 GHz, below the first Fresnel zone radius sqrt(λ d) of an occluder more
than 0.3 m from the scatterer, where sharp geometric shadows are already an approximation
(docs/integrator.md §"Visibility reuse")."""

XML_PARAMETERS: tuple[str, ...] = (
    "scatterer_density", "scatterers_per_cell", "max_depth", "chunk_lanes", "seed",
    "bins_per_cell", "beam_cull", "rays", "ray_cover", "capture", "ghosts", "plane_normal",
    "slab_width", "visibility_feature", "block_kernel")
"""The fields a scene's ``<integrator type="radar">`` may set (the integrator's parameters, in
the order of its provenance record ``integrator``)."""

_FLOATS = ("scatterer_density", "scatterers_per_cell", "beam_cull", "ray_cover", "slab_width",
           "visibility_feature")

ALIASES = {"density": "scatterer_density"}
"""Keyword spellings accepted for a field (``trace(..., density=...)``)."""


@dataclass(frozen=True)
class TraceOptions:
    """How to trace an acquisition: sampling, kernels, multipath, signal and run options.

    Every field defaults to ``None``, "not set at this layer" (module docstring); units as
    stated. Build one with keywords (``TraceOptions(max_depth=3)``), change one with
    :meth:`replace`, and get the effective request with :meth:`resolve`.

    Attributes
    ----------
    scatterer_density : float or None
        Surface scatterers per m² (default: ``scatterers_per_cell`` per resolution cell).
    scatterers_per_cell : float
        Surface scatterers per range x azimuth cell (default 9; cell: range resolution x
        :data:`AZIMUTH_CELL`).
    max_depth : int
        Hits per ray, the paper's N_HITS (default 1: direct backscatter only; ``k > 1``:
        multipath with up to ``k - 1`` specular reflections; at most 8).
    chunk_lanes : int
        Scatterer x sweep pairs per kernel launch (< 2^26; default 2^24).
    seed : int
        Seed of every draw of the run: scatterer positions and speckle, analytic targets
        added on top, thermal noise (default 0).
    bins_per_cell : int
        Histogram bins per range cell (default 16; 1..256).
    beam_cull : float
        Cull scatterers beyond this many beamwidths in direction sine (default 2; ``inf``:
        none).
    rays : int
        Multipath rays per sweep (default 4096; 2D mode: the size of the fan).
    ray_cover : float
        Half-width of the ray grid in beamwidths (default 1: the main lobe to the first nulls).
    capture : {"tent", "box"}
        Ray-tube capture kernel (default ``"tent"``; :mod:`mitsar.model.multipath`).
    ghosts : bool
        Bistatic double-lobe scattering back to the receiver at every hit after the first
        (default False, as the paper).
    plane_normal : tuple of 3 float or None
        2D mode: rays in the plane through the antenna containing the boresight with this
        normal; ``None``: 3-D (default).
    slab_width : float
        Width of the 2D mode's scatterer slab [m] (default :data:`AZIMUTH_CELL`).
    visibility_feature : float
        Smallest occluder (or gap) width [m] that shadow rays shared across sweeps resolve
        (default 0.03; 0: a shadow ray per sweep; docs/integrator.md §"Visibility reuse").
    block_kernel : bool
        Direct backscatter of static 3-D scenes by the block kernel (default True;
        docs/integrator.md §"Performance").
    rvp : bool
        Keep the residual video phase ``-K tau^2/2`` (default True).
    normalized : bool
        Unit amplitude per unit sqrt(RCS), no range loss (default False).
    noise : bool
        Add receiver noise ``k T0 F f_s`` (needs ``radar.noise_figure_db``; default False).
    orders : tuple of int or None
        Path orders kept in the raw data (0: direct backscatter); ``None``: all (default).
    physical_optics : bool or tuple of str
        Physical optics of planar facets: every mesh with a radar material (``True``) or the
        shapes with these ids (default False; docs/physical_optics.md §5).
    deterministic : bool
        Bit-identical data run after run and on any thread count (default True;
        docs/integrator.md §"Determinism").
    backscatter : bool
        Trace the direct backscatter of surface scatterers and point targets (default True).
    receiver_offset : tuple of 3 float or None
        Bistatic receiver at the transmitter plus this world-frame offset [m] (``None``:
        monostatic; needs ``backscatter=False``).
    receiver_look : Look or None
        Mounting of the bistatic receiving antenna (``None``: the transmitter's).
    receiver_visibility : bool
        Receive channels away from their transmitter: every receiver's own shadow rays for the
        direct backscatter (default True; docs/interferometry.md §8 "Visibility per
        receiver"); False: the transmitter's, shared (faster; its deposits differ only near
        shadow edges that lie between the phase centres).
    sweeps : slice, tuple of int or None
        Sweeps of the acquisition to trace (``None``: all).
    channel : int
        The receive channel traced, of a radar with phase centres (default 0;
        :func:`mitsar.simulate_scene` traces every channel; docs/interferometry.md).
    scene_params : mapping or None
        Values of the scene's ``<default>`` parameters (:func:`mitsar.scene.load_scene`).
    progress : bool
        Show a progress bar (default False).
    """

    # The integrator's parameters (XML_PARAMETERS, in that order)
    scatterer_density: float | None = None
    scatterers_per_cell: float | None = None
    max_depth: int | None = None
    chunk_lanes: int | None = None
    seed: int | None = None
    bins_per_cell: int | None = None
    beam_cull: float | None = None
    rays: int | None = None
    ray_cover: float | None = None
    capture: str | None = None
    ghosts: bool | None = None
    plane_normal: tuple[float, float, float] | None = None
    slab_width: float | None = None
    visibility_feature: float | None = None
    block_kernel: bool | None = None
    # The signal and the run (Python and TOML)
    rvp: bool | None = None
    normalized: bool | None = None
    noise: bool | None = None
    orders: tuple[int, ...] | None = None
    physical_optics: bool | tuple[str, ...] | None = None
    deterministic: bool | None = None
    backscatter: bool | None = None
    receiver_offset: tuple[float, float, float] | None = None
    receiver_look: Look | None = None
    receiver_visibility: bool | None = None
    sweeps: Any = None
    channel: int | None = None
    scene_params: Mapping[str, Any] | None = None
    progress: bool | None = None

    # ---- layers ----------------------------------------------------------------------------

    def given(self) -> dict[str, Any]:
        """The fields set at this layer (not ``None``)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if getattr(self, f.name) is not None}

    def replace(self, where: str = "TraceOptions", **changes: Any) -> TraceOptions:
        """A copy with some fields set (``None`` values and unknown names: see below).

        Parameters
        ----------
        where : str
            Who asks, for error messages.
        **changes
            Field values; ``None`` leaves a field as it is; :data:`ALIASES` are accepted.

        Raises
        ------
        ParameterError
            For a name that is no field, or a value the field does not accept.
        """
        fields = {f.name for f in dataclasses.fields(self)}
        values: dict[str, Any] = {}
        for name, value in changes.items():
            key = ALIASES.get(name, name)
            if key not in fields:
                raise ParameterError(where, name, f"an option of TraceOptions, one of "
                                     f"{sorted(fields | set(ALIASES))}", value)
            if value is not None:
                values[key] = _normalised(key, value)
        changed = dataclasses.replace(self, **values)
        changed.over(DEFAULTS).validate(where)
        return changed

    def over(self, base: TraceOptions) -> TraceOptions:
        """These options laid over ``base``: fields set here win."""
        return dataclasses.replace(base, **self.given())

    def resolve(self, where: str = "TraceOptions") -> TraceOptions:
        """The effective request: :data:`DEFAULTS` under these options, validated.

        Raises
        ------
        ParameterError
            Naming ``where``, the first invalid field, what was expected and what was found.
        """
        resolved = self.over(DEFAULTS)
        resolved.validate(where)
        return resolved

    @classmethod
    def from_xml(cls, values: Mapping[str, Any], where: str = "radar") -> TraceOptions:
        """The layer a scene's ``<integrator type="radar">`` sets (property values already
        checked against :data:`XML_PARAMETERS`), validated over the defaults."""
        return cls().replace(where, **dict(values))

    # ---- derived -----------------------------------------------------------------------------

    def density(self, radar: Radar) -> float:
        """Surface scatterers per m²: given, or ``scatterers_per_cell`` per resolution cell."""
        if self.scatterer_density is not None:
            return float(self.scatterer_density)
        return self.scatterers_per_cell / (radar.range_resolution * AZIMUTH_CELL)

    def integrator_dict(self) -> dict[str, Any]:
        """The integrator's parameters as a plain dict (the products' ``integrator`` record)."""
        return {name: getattr(self, name) for name in XML_PARAMETERS}

    # ---- validation --------------------------------------------------------------------------

    def validate(self, where: str) -> None:
        """Raise ParameterError naming the first invalid field (of a resolved request)."""
        def integer(name: str, low: int, high: int | None = None) -> None:
            value = getattr(self, name)
            bound = f"an integer in [{low}, {high}]" if high else f"an integer >= {low}"
            checks.integer(where, name, value, low, bound)
            if high is not None and value > high:
                raise ParameterError(where, name, bound, value)

        if self.scatterer_density is not None:
            checks.positive(where, "scatterer_density", self.scatterer_density,
                            "None or a finite number > 0")
        for name in ("scatterers_per_cell", "ray_cover", "slab_width"):
            checks.positive(where, name, getattr(self, name))
        for name in ("slab_width", "visibility_feature"):  # lengths [m]
            if abs(getattr(self, name)) > checks.MAX_LENGTH:
                raise ParameterError(where, name, f"a length within {checks.MAX_LENGTH:g} m",
                                     getattr(self, name))
        integer("max_depth", 1, MAX_DEPTH)
        integer("chunk_lanes", 1, MAX_LANES - 1)
        integer("rays", 1, MULTIPATH_CHUNK_LANES)
        if self.capture not in CAPTURE_KINDS:
            raise ParameterError(where, "capture", f"one of {list(CAPTURE_KINDS)}", self.capture)
        for name in ("ghosts", "block_kernel", "rvp", "normalized", "noise", "deterministic",
                     "backscatter", "progress", "receiver_visibility"):
            checks.boolean(where, name, getattr(self, name))
        for name in ("plane_normal", "receiver_offset"):
            value = getattr(self, name)
            if value is None:
                continue
            vector = np.asarray(value, dtype=float)
            if vector.shape != (3,) or not np.all(np.isfinite(vector)) or (
                    name == "plane_normal" and not np.linalg.norm(vector) > 0):
                expected = ("None (3D) or a non-zero 3-vector (2D mode: normal of the plane of "
                            "the rays)" if name == "plane_normal"
                            else "None (monostatic) or a finite 3-vector [m]")
                raise ParameterError(where, name, expected, value)
        integer("seed", 0)
        integer("channel", 0)
        integer("bins_per_cell", 1, 256)
        checks.finite(where, "visibility_feature", self.visibility_feature,
                      "a width >= 0 m (0: a shadow ray per sweep)")
        if not self.visibility_feature >= 0:
            raise ParameterError(where, "visibility_feature", "a width >= 0 m (0: a shadow ray "
                                 "per sweep)", self.visibility_feature)
        if not checks.is_real(self.beam_cull) or not self.beam_cull > 0:
            raise ParameterError(where, "beam_cull", "a number of beamwidths > 0 (inf: no "
                                 "culling)", self.beam_cull)
        if self.orders is not None and (not all(isinstance(o, int | np.integer) and o >= 0
                                                for o in self.orders)):
            raise ParameterError(where, "orders", "None or path orders (integers >= 0)",
                                 self.orders)
        if not (isinstance(self.physical_optics, bool) or (
                isinstance(self.physical_optics, tuple)
                and all(isinstance(s, str) for s in self.physical_optics))):
            raise ParameterError(where, "physical_optics", "a bool or shape ids",
                                 self.physical_optics)
        if self.receiver_look is not None and not isinstance(self.receiver_look, Look):
            raise ParameterError(where, "receiver_look", "None or a mitsar.Look",
                                 self.receiver_look)


def _normalised(name: str, value: Any) -> Any:
    """A field value in its canonical type (vectors as float tuples, ints as floats where the
    field is a float, orders as a tuple of int), or the value itself when it is not of a
    convertible kind (validation then names it)."""
    if name in ("plane_normal", "receiver_offset"):
        try:
            return tuple(float(v) for v in np.ravel(np.asarray(value, dtype=float)))
        except (TypeError, ValueError):
            return value
    if name in _FLOATS and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if name == "orders" and not isinstance(value, str):
        wanted = np.atleast_1d(np.asarray(value))
        if wanted.ndim == 1 and np.issubdtype(wanted.dtype, np.integer):
            return tuple(int(o) for o in wanted)
        return value
    if name == "physical_optics" and not isinstance(value, bool | str):
        try:
            return tuple(value)
        except TypeError:
            return value
    if name == "sweeps" and not isinstance(value, slice):
        return value
    return value


DEFAULTS = TraceOptions(
    scatterer_density=None, scatterers_per_cell=9.0, max_depth=1,
    chunk_lanes=DEFAULT_CHUNK_LANES, seed=0, bins_per_cell=hg.DEFAULT_BINS_PER_CELL,
    beam_cull=2.0, rays=DEFAULT_RAYS, ray_cover=1.0, capture="tent", ghosts=False,
    plane_normal=None, slab_width=AZIMUTH_CELL, visibility_feature=DEFAULT_VISIBILITY_FEATURE,
    block_kernel=True, rvp=True, normalized=False, noise=False, orders=None,
    physical_optics=False, deterministic=True, backscatter=True, receiver_offset=None,
    receiver_look=None, receiver_visibility=True, sweeps=None, channel=0, scene_params=None,
    progress=False)
"""The bottom layer: every default of a trace request."""
