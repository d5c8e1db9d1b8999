"""The one deposit of every mechanism: a contribution into the range histogram.

docs/design.md §5.5.

A contribution of amplitude ``a`` over a path of one-way-equivalent range ``R`` (half the path
length) with rate ``dR/dt`` adds ``a exp{j 2 pi (f_c tau_0 - K tau_0^2 / 2 + phi)}``, ``tau_0 =
2R/c``, at the apparent range ``R + (f_c / K) dR/dt``, split linearly between its two
neighbouring bins. The formulas are those of :mod:`mitsar.model.histogram`, called here on Dr.Jit
arrays (the packed :class:`~.constants.Constants` stand in for the radar). The block kernel
(:mod:`.blocks`) deposits the same values, advanced from a chunk's middle sweep, as packets of
both bins.
"""

from __future__ import annotations

from typing import Any

import drjit as dr
import mitsuba as mi

from mitsar.model import histogram as hg
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.plugins.integrators.radar.constants import Constants


def deposit(constants: Constants, re: Any, im: Any, base: Any, slant_range: Any, range_rate: Any,
            amplitude: Any, extra_cycles: Any, active: Any) -> None:
    """Scatter-add one complex contribution per lane into the histogram ``re + j im``.

    Parameters
    ----------
    constants : Constants
        ``fc``, ``chirp_rate``, ``rvp``, ``first_range``, ``inv_step``, ``last_lower``.
    re, im : mi.Float64
        Histogram buffer, bin ``j`` of histogram row ``h`` at ``h * bins + j``.
    base : mi.UInt32
        Index of bin 0 of each lane's histogram row (sweep and order).
    slant_range : mi.Float64
        Half the path length at mid-sweep [m].
    range_rate : mi.Float64 or mi.Float
        Its time derivative [m/s].
    amplitude : mi.Float
        Amplitude [sqrt(W)], or per unit sqrt(RCS) when normalised.
    extra_cycles : array or None
        Extra phase [cycles] (frozen speckle).
    active : mi.Bool
        Lanes that deposit; lanes whose apparent range leaves the grid are dropped.
    """
    f64, f32 = mi.Float64, mi.Float
    r_app = hg.apparent_range(slant_range, f64(range_rate), constants)
    lower, w_lo, w_hi = hg.split_weights(
        (r_app - constants["first_range"]) * constants["inv_step"], dr.floor)
    active = active & (lower >= 0.0) & (lower < constants["last_lower"])
    cycles = hg.deposit_cycles(slant_range * (2.0 / SPEED_OF_LIGHT), constants,
                               constants["rvp"])
    if extra_cycles is not None:
        cycles = cycles + f64(extra_cycles)
    # Wrapped in float64 (f_c tau ~ 2e4 cycles), then float32 is exact to ~4e-7 rad.
    sin_p, cos_p = dr.sincos((2.0 * dr.pi) * f32(cycles - dr.floor(cycles)))
    v_re, v_im = f64(amplitude * cos_p), f64(amplitude * sin_p)
    index = base + mi.UInt32(dr.select(active, lower, 0.0))
    for offset, weight in ((0, w_lo), (1, w_hi)):
        dr.scatter_reduce(dr.ReduceOp.Add, re, v_re * weight, index + offset, active)
        dr.scatter_reduce(dr.ReduceOp.Add, im, v_im * weight, index + offset, active)
