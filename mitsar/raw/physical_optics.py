"""Physical-optics echoes of a scene's planar facets and their bounce chains into the range
histograms (docs/physical_optics.md §5).

The facets of the shapes that opt in (:func:`mitsar.scene.facets.scene_facets`) are split once
per acquisition into sub-facets that are each in their own far field for the nearest antenna
position of the track (:func:`mitsar.model.physical_optics.subfacet_size`) and no larger than a
quarter range cell (so each deposits at one range). The bounce chains of the facets (single
facets, dihedral pairs, trihedral triples, up to ``max_length`` reflections) are enumerated
once (:func:`mitsar.model.bounce_chains.facet_chains`, pruned by the beam); each chain ends on
the sub-facets of its last facet. For every sweep, chain and sub-facet ``j``:

    a_j = sqrt(P_T G² λ² / (4π)²) · sqrt(P(entry) P(exit)) · S_j / (√(4π) R_t R_r),

``S_j`` the chain's PO amplitude through the sub-facet with the materials' ``Γ(θ_m) R``
(:func:`mitsar.model.bounce_chains.chain_echo`), ``P`` the one-way power pattern toward the
first and the last reflection point, deposited like every other contribution
(:mod:`mitsar.model.histogram`) at the delay ``(R_t + R_r)/c`` of the path through the
centroid, its Doppler, and order = the chain's length. Shadowing: a ``ray_test`` from the
antenna to the last reflection point and, for chains, one to the first. Facets of moving shapes
are moved to their mid-sweep position, rigidly with rotating shapes and paths
(:mod:`mitsar.model.geometry.rigid_motion`; docs/integrator.md §Moving objects). NumPy,
vectorised over sweep × chain × sub-facet lanes in blocks; no Python loop over sweeps.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.model import histogram as hg
from mitsar.model import physical_optics as po
from mitsar.model.bounce_chains import chain_echo, facet_chains, facets_in_beam, mirror_points
from mitsar.model.elements import element_field_pattern
from mitsar.model.geometry.antenna import direction_sines, one_way_pattern
from mitsar.model.geometry.rigid_motion import RigidMotion
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import radar_equation_amplitude
from mitsar.scene.facets import FacetSet, segments_visible

__all__ = ["MAX_CHAIN_FACETS", "MAX_CHAIN_ROWS", "MAX_SUBFACETS", "FacetEchoes"]

MAX_SUBFACETS = 400_000
"""Refuse more sub-facets than this (a large wall near the track): choose the shapes by id."""

MAX_CHAIN_ROWS = 2_000_000
"""Refuse more (chain, sub-facet) pairs than this (many mutually facing facets and a deep
``max_depth``): choose fewer shapes or a smaller ``max_depth``."""

MAX_CHAIN_FACETS = 2048
"""Refuse bounce chains (``max_depth > 2``) among more facets than this: their pairwise link
test holds facets² × 3 values (100 MB here)."""

_BLOCK_LANES = 1 << 16
"""Sweep × chain × sub-facet lanes per block (bounds the clipping temporaries to ~100 MB)."""

_SWEEP_BLOCK = 256
"""Sweeps per block of the set-up's nearest-range and beam tests."""


class FacetEchoes:
    """PO echoes of a facet set along one acquisition, deposited sweep block by sweep block.

    Parameters
    ----------
    radar : Radar
    scene : mitsuba.Scene
        For the shadow rays (in the state of the sweeps being deposited).
    facets : FacetSet
        The facets that use physical optics.
    geometry : SweepGeometry
        Platform state per sweep of the whole acquisition
        (:func:`mitsar.raw.product.sweep_geometry`).
    frames : numpy.ndarray, shape (sweeps, 3, 3)
        Antenna-to-world rotations per sweep.
    ranges : numpy.ndarray
        Apparent ranges of the histogram bins [m].
    bins_per_cell : int
        Histogram bins per range cell.
    max_length : int
        Longest chain (reflections): 1 single facets only, 2 dihedrals, 3 trihedrals.
    velocities : numpy.ndarray, shape (len(facets.shape_ids), 3), optional
        Velocity of each selected shape [m/s] (default static).
    beam_cull : float
        Beamwidths of direction sine within which a chain's first and last facets must come
        at some sweep (the integrator's ``beam_cull``).
    motions : list of RigidMotion or None, optional
        Rigid motion of each selected shape (None: static); replaces ``velocities`` (for
        rotating shapes and paths). The Doppler of a reflection point is its rigid-body
        velocity; a chain's image moves with its mirror planes' points, not their turning.
    receivers : tuple of (ndarray (sweeps, 3) or None), optional
        The receive channels of one transmitter (``geometry``: the transmitter's phase
        centre per sweep), as the integrator's ``channel_receivers``: None where a receiver
        is the transmitter, else its position per sweep [m]. Each gets its own echo of every
        chain and sub-facet (the scattered direction and range toward it, its pattern, its
        shadow ray from the last reflection point, the path's rate) in its own histogram;
        the chains and their lit apertures are the transmitter's (docs/interferometry.md §8).
    beams : tuple of (ElementBeam, ElementBeam, float), optional
        Per receiver, its channel's (transmit, receive) element beams and gain ratio
        ``sqrt(G_t G_r) / G`` (the integrator's ``channel_beams``): a receive element with a
        beam of its own weights its echoes by its own one-way pattern toward the last
        reflection point and its gain (:func:`mitsar.model.elements.channel_amplitude_factor`'s
        receive part), in the frame of the transmitter's antenna (``frames``, ``radar``: the
        radar's, or the transmit element's own beam that the tracer follows).
    """

    def __init__(self, radar: Radar, scene: Any, facets: FacetSet, geometry: dict,
                 frames: NDArray, ranges: NDArray, bins_per_cell: int, max_length: int = 1,
                 velocities: NDArray | None = None, beam_cull: float = 2.0,
                 motions: list[RigidMotion | None] | None = None,
                 receivers: tuple[NDArray | None, ...] | None = None,
                 beams: tuple[tuple[Any, Any, float], ...] | None = None) -> None:
        self.radar, self.scene, self.facets = radar, scene, facets
        self.receivers, self.beams = receivers, beams
        self.geometry, self.frames, self.ranges = geometry, frames, ranges
        self.step = hg.range_step(radar, bins_per_cell)
        self.times = np.asarray(geometry.slow_time, float) + radar.sweep_duration / 2
        positions = np.asarray(geometry.position, dtype=np.float64)
        shape_velocity = (np.zeros((len(facets.shape_ids), 3)) if velocities is None
                          else np.asarray(velocities, dtype=np.float64))
        tri = np.asarray(facets.triangles)
        self.facet_velocity = shape_velocity[facets.shape] if len(tri) else np.zeros((0, 3))
        self.motions = motions
        self._shape_velocity = shape_velocity
        centre = tri.mean(axis=1)
        radius = np.linalg.norm(tri - centre[:, None], axis=-1).max(axis=1, initial=0.0)
        nearest = np.full(len(tri), np.inf)
        in_beam = np.zeros(len(tri), dtype=bool)
        for start in range(0, len(positions), _SWEEP_BLOCK):    # blocks of sweeps
            block = slice(start, start + _SWEEP_BLOCK)
            moved = self._moved(centre[None], facets.shape[None], self.times[block, None])
            nearest = np.minimum(nearest, np.linalg.norm(
                moved - positions[block, None], axis=-1).min(axis=0, initial=np.inf))
            in_beam |= facets_in_beam(moved, radius, positions[block], frames[block],
                                      radar.azimuth_beamwidth, radar.elevation_beamwidth,
                                      beam_cull)
        nearest = np.maximum(nearest - radius, radar.wavelength)
        size = np.minimum(po.subfacet_size(nearest, radar.wavelength),
                          radar.range_resolution / 4)
        longest = np.linalg.norm(tri - np.roll(tri, -1, axis=1), axis=-1).max(axis=1,
                                                                            initial=0.0)
        expected = int(np.sum(np.maximum(np.ceil(longest / size), 1) ** 2))
        if expected > MAX_SUBFACETS:
            raise ParameterError("physical_optics", "physical_optics",
                                 f"shapes that split into <= {MAX_SUBFACETS} far-field "
                                 f"sub-facets (edge <= sqrt(λR/16) and <= a quarter range "
                                 f"cell); choose fewer or smaller shapes by id",
                                 f"{expected} sub-facets for {list(facets.shape_ids)}")
        self.triangles, self.parent = po.subdivide_facets(tri, np.full(len(tri), 3), size)
        self.shape = facets.shape[self.parent]
        self.velocity = self.facet_velocity[self.parent]
        if max_length > 1 and len(tri) > MAX_CHAIN_FACETS:
            raise ParameterError("physical_optics", "physical_optics",
                                 f"<= {MAX_CHAIN_FACETS} facets (triangles) for bounce chains "
                                 "(max_depth > 2): choose fewer shapes by id or max_depth <= 2",
                                 f"{len(tri)} triangles of {list(facets.shape_ids)}")
        self.chains = facet_chains(tri, positions, max_length, in_beam)
        self.rows = [self._rows(chains) for chains in self.chains]
        total = sum(len(sub) for _, sub in self.rows)
        if total > MAX_CHAIN_ROWS:
            raise ParameterError("physical_optics", "max_depth",
                                 f"<= {MAX_CHAIN_ROWS} (bounce chain, sub-facet) pairs: a "
                                 "smaller max_depth or fewer shapes by id",
                                 f"{total} for chains of up to {max_length} facets of "
                                 f"{list(facets.shape_ids)}")

    def __len__(self) -> int:
        return len(self.triangles)

    @property
    def chain_counts(self) -> list[int]:
        """Number of chains of each length 1, 2, … (pruned by the beam)."""
        return [len(c) for c in self.chains]

    def _rows(self, chains: NDArray) -> tuple[NDArray, NDArray]:
        """(prefix facets (R, n−1), sub-facet of the last facet (R,)) of each chain × each
        sub-facet of its last facet."""
        order = np.argsort(self.parent, kind="stable")
        counts = np.bincount(self.parent, minlength=len(self.facets.triangles))
        starts = np.cumsum(counts) - counts
        per = counts[chains[:, -1]]
        rep = np.repeat(np.arange(len(chains)), per)
        within = np.arange(int(per.sum())) - np.repeat(np.cumsum(per) - per, per)
        return chains[rep, :-1], order[starts[chains[rep, -1]] + within]

    def histogram(self, sweeps: NDArray, orders: int, rvp: bool = True,
                  normalized: bool = False) -> NDArray[np.complex128]:
        """Histograms of the PO echoes of some sweeps, shape (len(sweeps), orders, bins), or
        (len(sweeps), receivers, orders, bins) with ``receivers`` [sqrt(W)]; a chain of n
        facets deposits at order n (chains longer than ``orders − 1`` are left out). ``rvp``,
        ``normalized`` as :func:`mitsar.raw.traced.trace`; the scene must be in the state of
        these sweeps (its shapes where they are at mid-sweep) for the shadow rays."""
        sweeps = np.asarray(sweeps, dtype=np.int64)
        per_receiver = () if self.receivers is None else (len(self.receivers),)
        out = np.zeros((len(sweeps), *per_receiver, orders, len(self.ranges)),
                       dtype=np.complex128)
        for length, (prefix, sub) in enumerate(self.rows, start=1):   # chain lengths (≤ 7)
            if length >= orders or len(sub) == 0:
                continue
            lanes = len(sweeps) * len(sub)
            for start in range(0, lanes, _BLOCK_LANES):               # blocks of lanes
                lane = np.arange(start, min(start + _BLOCK_LANES, lanes))
                row, pick = lane // len(sub), lane % len(sub)
                self._deposit(out, length, row, sweeps[row], prefix[pick], sub[pick], rvp,
                              normalized)
        return out

    def _deposit(self, out: NDArray, length: int, row: NDArray, sweeps: NDArray,
                 prefix: NDArray, sub: NDArray, rvp: bool, normalized: bool) -> None:
        """Every receiver's echoes of one block of (sweep, chain, sub-facet) lanes."""
        t = self.times[sweeps]
        p = self.geometry.position[sweeps]
        frames = self.frames[sweeps]
        last = self._moved(self.triangles[sub], self.shape[sub], t)
        receivers = ([None] if self.receivers is None
                     else [None if q is None else q[sweeps] for q in self.receivers])
        front = np.zeros(len(p), dtype=bool)             # cheap cull: behind every antenna
        for k, q in enumerate(receivers):
            front |= self._receive(last.mean(axis=1) - (p if q is None else q), frames, k) > 0
        if not np.any(front):
            return
        row, sweeps, prefix, sub, t, p = (a[front] for a in (row, sweeps, prefix, sub, t, p))
        frames, last = frames[front], last[front]
        tri = self.facets.triangles
        links = [self._moved(tri[prefix[:, m]], self.facets.shape[prefix[:, m]], t)
                 for m in range(length - 1)] + [last]
        shapes = np.concatenate([self.facets.shape[prefix], self.shape[sub][:, None]], axis=1)
        normals = [po.facet_plane(link)[1] for link in links]
        lanes = _Lanes(row, sweeps, prefix, sub, t, p, frames, links, shapes, normals)
        for k, q in enumerate(receivers):                # the transmitter's receivers (a few)
            self._deposit_receiver(out, length, lanes, k, None if q is None else q[front],
                                   rvp, normalized)

    def _deposit_receiver(self, out: NDArray, length: int, lanes: _Lanes, receiver: int,
                          q: NDArray | None, rvp: bool, normalized: bool) -> None:
        """Receiver ``receiver``'s echoes (at ``q`` (lanes, 3) [m], None: at the transmitter)
        of a block's lanes into its histogram rows."""
        radar = self.radar
        row, sweeps, prefix, sub, t, p, frames, links, shapes, normals = lanes
        index = (row,) if self.receivers is None else (row, np.full(len(row), receiver))
        monostatic = q is None
        q = p if monostatic else q
        echo = chain_echo(links, p, q, radar.wavelength,
                          lambda m, cos: self.facets.reflection(cos, shapes[:, m]))
        _, _, p_tx = _pattern(echo.entry - p, frames, radar)
        p_rx = self._receive(echo.exit - q, frames, receiver)
        pattern2 = p_tx * p_rx
        keep = (echo.amplitude != 0) & (pattern2 > 0)
        # shadow rays: the exit to the receiver, then the entry to the transmitter
        for point, normal, antenna in ((echo.exit, normals[-1], q), (echo.entry, normals[0], p)):
            if np.any(keep):
                seen = segments_visible(self.scene, point[keep], normal[keep], antenna[keep])
                keep[np.flatnonzero(keep)[~seen]] = False
            if length == 1 and monostatic:  # one point, one antenna: one ray
                break
        if not np.any(keep):
            return
        amplitude, r_t, r_r = echo.amplitude[keep], echo.transmit_range[keep], \
            echo.receive_range[keep]
        pattern2 = pattern2[keep]
        if normalized:
            amplitude = np.sqrt(pattern2) * amplitude
        else:
            if self.beams is not None:  # sqrt(G_t G_r) / G: the radar equation's gain
                pattern2 = pattern2 * self.beams[receiver][2] ** 2
            amplitude = radar_equation_amplitude(radar, 1.0, r_t, r_r,
                                                 two_way_pattern=pattern2) * amplitude
        # path L = |c − I| + |q − c|, its rate with the image moving as the mirrored platform
        # velocity in planes that translate with their shapes (docs/multipath.md, Doppler);
        # the receiver moves with the platform
        v_p = self.geometry.velocity[sweeps][keep]
        v_image = v_p
        for m in range(length - 1):
            anchor_velocity = (self.facet_velocity[prefix[keep, m]] if self.motions is None
                               else self._velocity(links[m][keep].mean(axis=1),
                                                   self.facets.shape[prefix[keep, m]], t[keep]))
            v_image = mirror_points(v_image, anchor_velocity, normals[m][keep])
        point = echo.exit[keep]
        v_c = (self.velocity[sub[keep]] if self.motions is None
               else self._velocity(point, self.shape[sub[keep]], t[keep]))
        rate = (np.einsum("ni,ni->n", _unit(point - echo.image[keep]), v_c - v_image)
                + np.einsum("ni,ni->n", _unit(q[keep] - point), v_p - v_c))
        path = r_t + r_r
        cycles = hg.deposit_cycles(path / SPEED_OF_LIGHT, radar, 1.0 if rvp else 0.0)
        value = amplitude * np.exp(2j * np.pi * (cycles - np.floor(cycles)))
        hg.deposit(out, (*(i[keep] for i in index), np.full(int(keep.sum()), length)), value,
                   hg.apparent_range(0.5 * path, 0.5 * rate, radar), float(self.ranges[0]),
                   self.step)

    def _receive(self, offset: NDArray, frames: NDArray, receiver: int) -> NDArray:
        """One-way power pattern of receiver ``receiver`` toward ``offset`` (lanes, 3): the
        radar's, or its element's own beam (``beams``; its gain applied with the radar
        equation in :meth:`_deposit_receiver`)."""
        if self.beams is None:
            return _pattern(offset, frames, self.radar)[2]
        u = offset / np.maximum(np.linalg.norm(offset, axis=-1), 1e-300)[:, None]
        return element_field_pattern(*direction_sines(u, frames), self.beams[receiver][1]) ** 2

    def _moved(self, points: NDArray, shapes: NDArray, t: NDArray) -> NDArray:
        """``points`` (lanes, ..., 3) of facets of the selected shapes ``shapes`` (lanes,) at
        load, moved to slow times ``t`` (lanes,) [s] (lanes broadcast)."""
        if self.motions is None:   # translations: x + v t
            lanes = np.broadcast_shapes(shapes.shape, t.shape)
            extra = (1,) * (points.ndim - 1 - len(lanes))
            shift = self._shape_velocity[shapes] * t[..., None]
            return points + shift.reshape(lanes + extra + (3,))
        return _rigid_apply(self.motions, shapes, points, t, "move")

    def _velocity(self, points: NDArray, shapes: NDArray, t: NDArray) -> NDArray:
        """Rigid-body velocity [m/s] of the facet points ``points`` (lanes, 3) at ``t``."""
        return _rigid_apply(self.motions, shapes, points, t, "point_velocity")


class _Lanes(NamedTuple):
    """A block's lanes after the cull, shared by the receivers (:meth:`FacetEchoes._deposit`):
    histogram rows, sweeps, chain prefixes, sub-facets, slow times [s], transmitter positions
    [m], antenna frames, the chain's links [m], their shapes and unit normals."""

    row: NDArray
    sweeps: NDArray
    prefix: NDArray
    sub: NDArray
    t: NDArray
    p: NDArray
    frames: NDArray
    links: list[NDArray]
    shapes: NDArray
    normals: list[NDArray]


def _rigid_apply(motions: list[RigidMotion | None], shapes: NDArray, points: NDArray,
                 t: NDArray, method: str) -> NDArray:
    """``RigidMotion.move`` (or ``point_velocity``) of each lane's shape, lanes broadcast from
    ``shapes`` and ``t``; static shapes keep their points (velocity 0)."""
    lanes = np.broadcast_shapes(shapes.shape, t.shape)
    tail = points.shape[len(lanes):]
    x = np.broadcast_to(points, lanes + tail)
    shapes, t = np.broadcast_to(shapes, lanes), np.broadcast_to(t, lanes)
    out = np.array(x, dtype=float) if method == "move" else np.zeros(x.shape)
    for k in np.unique(shapes):          # the selected shapes (a few), not lanes
        if motions[k] is None:
            continue
        sel = shapes == k
        out[sel] = getattr(motions[k], method)(x[sel], t[sel])
    return out


def _unit(v: NDArray) -> NDArray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def _pattern(offset: NDArray, frames: NDArray, radar: Radar
             ) -> tuple[NDArray, NDArray, NDArray]:
    """Unit direction, distance and one-way power pattern toward ``offset`` (N, 3)."""
    distance = np.linalg.norm(offset, axis=-1)
    u = offset / np.maximum(distance, 1e-300)[:, None]
    u_az, u_el, cos_b = direction_sines(u, frames)
    return u, distance, one_way_pattern(u_az, u_el, radar.azimuth_beamwidth,
                                        radar.elevation_beamwidth, cos_b)
