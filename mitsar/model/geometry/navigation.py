"""Navigation errors: the track a drone's navigation system records against the one it flies.

A real platform flies a *true* trajectory; its navigation solution (GNSS/INS, motion capture,
visual odometry) records another, the *navigation* track. The echoes come from the true antenna
positions; every focuser only knows the navigation track. :class:`NavigationErrors` describes the
difference ``navigation - true`` as seeded processes (docs/navigation.md):

- constant offsets of position [m] and attitude [deg];
- random walks (integrated white noise): position increments of standard deviation
  ``q sqrt(dt)`` for ``q`` in m/sqrt(s) (a velocity white noise of two-sided PSD ``q^2``
  [m^2/s]), attitude likewise in deg/sqrt(s);
- coloured noise: first-order Gauss-Markov processes of stated standard deviation and
  correlation time tau (PSD ``2 sigma^2 tau / (1 + (2 pi f tau)^2)``), sampled exactly as the
  AR(1) recursion ``x_{k+1} = exp(-dt/tau) x_k + sigma sqrt(1 - exp(-2 dt/tau)) w_k``;
- vibration: sinusoids of given amplitude vector [m], frequency [Hz] and phase [rad];
- a lever arm [m] in the body frame between the navigation reference point and the antenna
  phase centre that the navigation solution does not account for: it records the reference
  point, ``true_antenna - R(attitude) lever_arm``.

:func:`navigation_track` samples the processes at ``sample_rate`` over the flight and returns
the navigation track as a :meth:`Trajectory.navigation` (cubic Hermite with the sampled
velocities), so every consumer evaluates it like any other trajectory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar import checks
from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import body_to_world
from mitsar.model.geometry.trajectory import Trajectory

__all__ = ["NavigationErrors", "Vibration", "describe_navigation", "navigation_track",
           "resolve_navigation"]

_WHERE = "NavigationErrors"

_UNITS = {"position_offset": "m", "position_random_walk": "m/sqrt(s)", "position_noise": "m",
          "position_correlation_time": "s", "attitude_offset_deg": "deg",
          "attitude_random_walk_deg": "deg/sqrt(s)", "attitude_noise_deg": "deg",
          "attitude_correlation_time": "s", "lever_arm": "m", "sample_rate": "Hz"}
"""Units of the fields bounded by :func:`mitsar.checks.check_units`."""


def _vector(name: str, value: Any, expected: str) -> tuple[float, float, float]:
    return tuple(float(v) for v in checks.vector(_WHERE, name, value, 3, expected))


def _non_negative_vector(name: str, value: Any, unit: str) -> tuple[float, float, float]:
    vec = _vector(name, value, f"3 finite numbers >= 0 [{unit}] (x, y, z)")
    if min(vec) < 0:
        raise ParameterError(_WHERE, name, f"3 finite numbers >= 0 [{unit}]", list(vec))
    return vec


@dataclass(frozen=True)
class Vibration(metaclass=checks.KnownFields):
    """A sinusoidal error ``amplitude sin(2 pi frequency t + phase)``.

    Attributes
    ----------
    amplitude : tuple of 3 float
        Amplitude per world axis [m].
    frequency : float
        Frequency [Hz] (> 0).
    phase : float
        Phase at t = 0 [rad].
    """

    amplitude: tuple[float, float, float]
    frequency: float
    phase: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "amplitude", _vector(
            "vibration.amplitude", self.amplitude, "3 finite numbers [m]"))
        object.__setattr__(self, "frequency", checks.positive(
            _WHERE, "vibration.frequency", self.frequency, "a finite frequency > 0 Hz"))
        object.__setattr__(self, "phase", checks.finite(_WHERE, "vibration.phase", self.phase,
                                                        "a finite phase [rad]"))
        checks.check_units(_WHERE, self, {"amplitude": "m", "frequency": "Hz", "phase": "rad"},
                           "vibration.")  # as [[trajectory.errors.vibration]] (issue 27)

    def at(self, t: NDArray) -> NDArray[np.float64]:
        """The displacement at times ``t`` [s], shape ``t.shape + (3,)`` [m]."""
        return np.sin(2 * math.pi * self.frequency * t + self.phase)[..., None] \
            * np.asarray(self.amplitude)

    def rate(self, t: NDArray) -> NDArray[np.float64]:
        """Its time derivative [m/s]."""
        return (2 * math.pi * self.frequency
                * np.cos(2 * math.pi * self.frequency * t + self.phase))[..., None] \
            * np.asarray(self.amplitude)


@dataclass(frozen=True)
class NavigationErrors(metaclass=checks.KnownFields):
    """What the navigation track records minus what the platform flies (seeded processes).

    Every field defaults to "no error"; units are SI except the attitude fields (degrees, as
    everywhere at the interface). See the module docstring for the models.

    Attributes
    ----------
    seed : int
        Seed of every random draw (recorded in the raw product).
    position_offset : 3 floats [m]
        Constant position error.
    position_random_walk : 3 floats [m/sqrt(s)]
        Random-walk intensity per axis: the error's standard deviation after ``t`` seconds is
        ``q sqrt(t)``.
    position_noise : 3 floats [m]
        Standard deviation of the Gauss-Markov position noise per axis.
    position_correlation_time : float [s]
        Its correlation time.
    vibration : tuple of Vibration
        Sinusoidal position errors.
    attitude_offset_deg, attitude_random_walk_deg, attitude_noise_deg : 3 floats
        The same for heading, pitch, roll [deg, deg/sqrt(s), deg].
    attitude_correlation_time : float [s]
        Correlation time of the attitude noise.
    lever_arm : 3 floats [m]
        Unaccounted antenna offset in the body frame (x forward, y left, z up).
    sample_rate : float [Hz]
        Rate at which the processes are sampled (the navigation track interpolates between, as
        a navigation solution output at this rate would be). The velocity error of a random
        walk is white: its standard deviation at this rate is ``q sqrt(sample_rate)``.
    """

    seed: int = 0
    position_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    position_random_walk: tuple[float, float, float] = (0.0, 0.0, 0.0)
    position_noise: tuple[float, float, float] = (0.0, 0.0, 0.0)
    position_correlation_time: float = 0.1
    vibration: tuple[Vibration, ...] = field(default_factory=tuple)
    attitude_offset_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    attitude_random_walk_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    attitude_noise_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    attitude_correlation_time: float = 0.1
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sample_rate: float = 200.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "seed", checks.integer(_WHERE, "seed", self.seed, 0))
        for name, unit in (("position_random_walk", "m/sqrt(s)"), ("position_noise", "m"),
                           ("attitude_random_walk_deg", "deg/sqrt(s)"),
                           ("attitude_noise_deg", "deg")):
            set_(self, name, _non_negative_vector(name, getattr(self, name), unit))
        for name, unit in (("position_offset", "m"), ("attitude_offset_deg", "deg"),
                           ("lever_arm", "m")):
            set_(self, name, _vector(name, getattr(self, name), f"3 finite numbers [{unit}]"))
        for name in ("position_correlation_time", "attitude_correlation_time"):
            set_(self, name, checks.positive(_WHERE, name, getattr(self, name),
                                             "a finite time > 0 s"))
        set_(self, "sample_rate", checks.positive(_WHERE, "sample_rate", self.sample_rate,
                                                  "a finite rate > 0 Hz"))
        checks.check_units(_WHERE, self, _UNITS)  # as [trajectory.errors] (issue 27)
        vibration = self.vibration
        if isinstance(vibration, Vibration | dict):
            vibration = (vibration,)
        try:
            items = tuple(v if isinstance(v, Vibration) else Vibration(**v) for v in vibration)
        except TypeError as error:
            raise ParameterError(_WHERE, "vibration", "Vibration objects or tables with "
                                 "amplitude [m], frequency [Hz] and optional phase [rad]",
                                 vibration) from error
        set_(self, "vibration", items)

    @classmethod
    def from_dict(cls, values: dict[str, Any], where: str = _WHERE) -> NavigationErrors:
        """Build from a plain dict (the TOML table ``[trajectory.errors]``), refusing unknown
        keys by name."""
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(values) - known)
        if unknown:
            raise ParameterError(where, unknown[0], f"one of {sorted(known)}",
                                 values[unknown[0]])
        return cls(**values)

    def describe(self) -> dict[str, Any]:
        """A JSON-serialisable description (provenance)."""
        out = {name: getattr(self, name) for name in self.__dataclass_fields__}
        out["vibration"] = [{"amplitude": list(v.amplitude), "frequency": v.frequency,
                             "phase": v.phase} for v in self.vibration]
        return {k: list(v) if isinstance(v, tuple) else v for k, v in out.items()}

    # --- the processes ----------------------------------------------------------------------
    def sample(self, duration: float) -> dict[str, NDArray[np.float64]]:
        """Sample the error processes over ``[0, duration]`` seconds.

        Returns
        -------
        dict
            ``time`` (n,) [s]; ``position``, ``velocity`` (n, 3) [m, m/s] (without the lever
            arm, which depends on the attitude); ``attitude`` (n, 3) [rad] (heading, pitch,
            roll).
        """
        duration = checks.positive(_WHERE, "duration", duration, "a finite time > 0 s")
        count = max(2, int(math.ceil(duration * self.sample_rate)) + 1)
        time = np.linspace(0.0, duration, count)
        dt = time[1] - time[0]
        rng = np.random.default_rng(self.seed)
        # One draw per process, always in this order, so that adding a process changes no other.
        draws = rng.standard_normal((4, count, 3))
        position = (np.asarray(self.position_offset)
                    + _random_walk(draws[0], self.position_random_walk, dt)
                    + _gauss_markov(draws[1], self.position_noise,
                                    self.position_correlation_time, dt))
        position = position + sum((v.at(time) for v in self.vibration), np.zeros((count, 3)))
        attitude = np.radians(np.asarray(self.attitude_offset_deg)
                              + _random_walk(draws[2], self.attitude_random_walk_deg, dt)
                              + _gauss_markov(draws[3], self.attitude_noise_deg,
                                              self.attitude_correlation_time, dt))
        # The stochastic part's rate by differences, the vibration's exactly.
        velocity = np.gradient(position - sum((v.at(time) for v in self.vibration),
                                              np.zeros((count, 3))), time, axis=0)
        velocity = velocity + sum((v.rate(time) for v in self.vibration), np.zeros((count, 3)))
        return {"time": time, "position": position, "velocity": velocity, "attitude": attitude}


def _random_walk(draw: NDArray, intensity: ArrayLike, dt: float) -> NDArray[np.float64]:
    """Integrated white noise starting at 0: increments ``N(0, q^2 dt)`` per step."""
    steps = draw[1:] * (np.asarray(intensity) * math.sqrt(dt))
    return np.vstack([np.zeros((1, 3)), np.cumsum(steps, axis=0)])


def _gauss_markov(draw: NDArray, sigma: ArrayLike, tau: float, dt: float) -> NDArray[np.float64]:
    """Stationary first-order Gauss-Markov process of standard deviation ``sigma``: the exact
    AR(1) discretisation, started from its stationary distribution (one ``lfilter`` call)."""
    decay = math.exp(-dt / tau)
    sigma = np.asarray(sigma, dtype=float)
    forcing = draw * (sigma * math.sqrt(1.0 - decay * decay))
    forcing[0] = draw[0] * sigma
    from scipy.signal import lfilter  # lazy: SciPy's signal tools are heavy

    return lfilter([1.0], [1.0, -decay], forcing, axis=0)


def navigation_track(true: Trajectory, errors: NavigationErrors) -> Trajectory:
    """The navigation track that ``errors`` make of the ``true`` trajectory.

    Parameters
    ----------
    true : Trajectory
        What the antenna phase centre flies (echoes come from here).
    errors : NavigationErrors

    Returns
    -------
    Trajectory
        A :meth:`Trajectory.navigation` sampled at ``errors.sample_rate`` with position,
        velocity and attitude ``true + error`` (the lever arm rotated by the true attitude).
    """
    if not isinstance(true, Trajectory):
        raise ParameterError("navigation_track", "true", "a mitsar.Trajectory", type(true))
    if not isinstance(errors, NavigationErrors):
        raise ParameterError("navigation_track", "errors", "a mitsar.NavigationErrors",
                             type(errors))
    sampled = errors.sample(true.duration)
    time = sampled["time"]
    attitude = true.attitude_at(time)
    lever = body_to_world(*attitude.T) @ np.asarray(errors.lever_arm)
    position = true.position(time) + sampled["position"] - lever
    velocity = true.velocity(time) + sampled["velocity"]
    nav_attitude = attitude + sampled["attitude"]
    return Trajectory.navigation(time, position, velocity, np.degrees(nav_attitude))


def resolve_navigation(where: str, true: Trajectory,
                       navigation: Trajectory | NavigationErrors | None) -> Trajectory | None:
    """The navigation track a simulation records for the ``true`` track (None: the same).

    Parameters
    ----------
    where : str
        Caller, for errors.
    true : Trajectory
        The flown track.
    navigation : Trajectory, NavigationErrors or None
        A recorded navigation track (it must cover the flight), errors to make one from the true
        track (:func:`navigation_track`), or None (ideal navigation).
    """
    if navigation is None:
        return None
    if isinstance(navigation, NavigationErrors):
        return navigation_track(true, navigation)
    if not isinstance(navigation, Trajectory):
        raise ParameterError(where, "navigation", "None, a mitsar.Trajectory (the recorded "
                             "track) or a mitsar.NavigationErrors", type(navigation))
    if navigation.duration < true.duration * (1 - 1e-12):
        raise ParameterError(where, "navigation", f"a track covering the flight "
                             f"(>= {true.duration:g} s)", f"{navigation.duration:g} s")
    return navigation


def describe_navigation(navigation: Trajectory | NavigationErrors | None) -> dict | None:
    """Provenance of a ``navigation`` argument (JSON-serialisable)."""
    if navigation is None:
        return None
    if isinstance(navigation, NavigationErrors):
        return {"errors": navigation.describe()}
    return {"track": navigation.describe()}
