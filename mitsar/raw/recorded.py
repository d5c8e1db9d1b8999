"""Real recorded data into the mitsar processing chain: arrays, files, and the AFRL GOTCHA set.

Model
-----
A recording is a matrix of complex samples, one row per sweep (or pulse) and one column per
RF frequency ``f_n`` on a uniform grid, plus the antenna phase-centre position of every row. For
a point scatterer at range ``R_k`` from the antenna of row k the samples are

``s[k, n] = A exp{ j phase_sign (4 pi / c) f_n (R_k - R_ref,k) }``

where ``R_ref,k`` is the range to a reference point the data were motion-compensated to (0 when
they were not). This is exactly a dechirped FMCW sweep after residual-video-phase removal, with
sample ``n`` at instantaneous frequency ``f_n`` (docs/design.md §5.6), so mitsar describes
it with an *equivalent* FMCW radar: ``N`` samples of step ``df`` form a sweep of bandwidth
``B = N df`` centred on ``f_c = f_0 + B/2`` (the frequency at the sweep-centred time origin),
sampled at ``f_s = N / T`` with ``K = B / T`` for a nominal sweep time ``T``. The range profile of
a row (FFT over ``n``) then covers ``c / (2 df)`` of range around the reference, and
back-projection looks every pixel up at ``R - R_ref,k``.

Products of :func:`raw_from_arrays` are ordinary raw products with two extra variables:
``reference_range`` (sweep) and ``frequency`` (sample); :func:`mitsar.focus.focus` sends them to
:func:`mitsar.focus.referenced.focus_referenced` (BPA on any grid). When the samples are true
FMCW sweeps with absolute range (no reference) and a sweep rate, pass ``continuous_motion=True``
to get a plain dechirped product that every algorithm accepts.

Files: :func:`read_raw` reads a mitsar raw product (netCDF), or the generic layout documented in
``docs/focusing.md`` from netCDF/HDF5/NPZ. :func:`read_gotcha` reads the AFRL GOTCHA volumetric
SAR phase histories (``data_3dsar_pass*_az*_*.mat``; Casteel et al., Proc. SPIE 6568, 2007).
"""

from __future__ import annotations

import glob
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import MitsarError, ParameterError
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import fast_time
from mitsar.version import __version__

FREQUENCY_TOLERANCE = 1e-3
"""Largest deviation of the frequencies from their linear fit, in frequency steps (GOTCHA's
float32 frequencies wobble by 3.4e-4 steps)."""

GENERIC_KEYS = ("samples", "frequencies", "antenna_positions", "reference_point",
                "reference_range", "sweep_times", "velocities", "boresight")
"""Variable names of the generic file layout (see ``docs/focusing.md``)."""


def _fit_frequencies(frequencies: ArrayLike, count: int) -> tuple[float, float]:
    """``(f_0, df)`` of a uniform frequency axis, after checking it is uniform."""
    values = np.asarray(frequencies, dtype=float)
    if values.ndim == 2:
        if not np.allclose(values, values[:1], rtol=0, atol=1e-6 * np.abs(values).max()):
            raise ParameterError("raw_from_arrays", "frequencies",
                                 "one frequency axis shared by all sweeps", "per-sweep axes")
        values = values[0]
    if values.ndim != 1 or len(values) != count:
        raise ParameterError("raw_from_arrays", "frequencies", f"{count} frequencies [Hz]",
                             values.shape)
    index = np.arange(count, dtype=float)
    step, first = np.polyfit(index, values, 1)
    if not step > 0:
        raise ParameterError("raw_from_arrays", "frequencies", "increasing frequencies [Hz]",
                             f"step {step:g} Hz")
    residual = np.abs(values - (first + step * index)).max() / step
    if residual > FREQUENCY_TOLERANCE:
        raise ParameterError("raw_from_arrays", "frequencies",
                             f"a uniform grid (deviations <= {FREQUENCY_TOLERANCE:g} steps)",
                             f"deviations of {residual:.3g} steps")
    return float(first), float(step)


def _vectors(name: str, value: ArrayLike, sweeps: int) -> NDArray[np.float64]:
    array = np.asarray(value, dtype=float)
    if array.shape != (sweeps, 3) or not np.all(np.isfinite(array)):
        raise ParameterError("raw_from_arrays", name, f"shape ({sweeps}, 3), finite [m]",
                             array.shape)
    return array


def equivalent_radar(first_frequency: float, frequency_step: float, samples: int,
                     sweep_duration: float = 1.0) -> Radar:
    """The FMCW radar whose dechirped sweep samples the RF frequencies ``f_0 + n df``.

    ``B = N df``, ``f_c = f_0 + B / 2``, ``T = sweep_duration``, ``f_s = N / T``; ``max_range``
    is just inside the unambiguous half range ``c / (4 df)`` and the azimuth beam is 90 deg
    wide, so back-projection uses every sweep unless told otherwise.
    """
    bandwidth = samples * frequency_step
    return Radar(carrier_frequency=first_frequency + bandwidth / 2, bandwidth=bandwidth,
                 sampling_frequency=samples / sweep_duration, prf=1.0 / sweep_duration,
                 max_range=0.999 * SPEED_OF_LIGHT / (4 * frequency_step),
                 azimuth_beamwidth_deg=90.0, elevation_beamwidth_deg=90.0)


def raw_from_arrays(samples: ArrayLike, frequencies: ArrayLike, antenna_positions: ArrayLike,
                    reference_point: ArrayLike | None = None,
                    sweep_times: ArrayLike | None = None, phase_sign: int = +1, *,
                    reference_range: ArrayLike | None = None,
                    velocities: ArrayLike | None = None, boresight: ArrayLike | None = None,
                    continuous_motion: bool = False,
                    attrs: dict[str, Any] | None = None) -> xr.Dataset:
    """Build a raw product from recorded samples (module docstring).

    Parameters
    ----------
    samples : array_like, shape (sweeps, N), complex
        One row per sweep/pulse, one column per RF frequency (dechirped, RVP removed).
    frequencies : array_like, shape (N,) or (sweeps, N)
        RF frequency of each column [Hz], uniformly spaced (fitted in float64).
    antenna_positions : array_like, shape (sweeps, 3)
        Antenna phase centre of each row [m] (the scene's frame).
    reference_point : array_like, shape (3,), optional
        Point the data were motion-compensated to: ``R_ref,k = |p_k - reference_point|``.
    sweep_times : array_like, shape (sweeps,), optional
        Time of each row [s]; sets velocities (finite differences) and the sweep rate.
    phase_sign : {+1, -1}
        Sign of the range phase in the data: +1 for ``exp(+j 4 pi f R / c)`` (mitsar's
        dechirp convention), -1 for ``exp(-j 4 pi f R / c)`` (e.g. GOTCHA, CPHD); -1 data are
        conjugated.
    reference_range : array_like, shape (sweeps,), optional
        ``R_ref,k`` directly [m] (e.g. GOTCHA's ``r0``); overrides ``reference_point``.
    velocities : array_like, shape (sweeps, 3), optional
        Antenna velocity [m/s]; by default from positions and ``sweep_times`` (or the row index).
    boresight : array_like, shape (sweeps, 3) or (3,), optional
        Antenna boresight; by default toward ``reference_point``, else straight down.
    continuous_motion : bool
        The rows are true FMCW sweeps (duty cycle 1) with absolute range: returns a plain
        dechirped product (needs ``sweep_times``; no reference) that RDA/WDA/FSA also accept,
        with the continuous-motion correction. Otherwise the product is *referenced*
        (stop-and-go) and focused by back-projection only.
    attrs : dict, optional
        Extra attributes (provenance).

    Returns
    -------
    xarray.Dataset
        A raw product (:mod:`mitsar.raw.product`) with ``frequency`` (sample) and, unless
        ``continuous_motion``, ``reference_range`` (sweep).
    """
    data = np.asarray(samples)
    if data.ndim != 2 or data.shape[0] < 2 or data.shape[1] < 8:
        raise ParameterError("raw_from_arrays", "samples",
                             "a complex array of shape (sweeps >= 2, samples >= 8)", data.shape)
    data = data.astype(np.complex128)
    if phase_sign not in (1, -1):
        raise ParameterError("raw_from_arrays", "phase_sign", "+1 or -1", phase_sign)
    if phase_sign == -1:
        data = np.conj(data)
    sweeps, count = data.shape
    first, step = _fit_frequencies(frequencies, count)
    positions = _vectors("antenna_positions", antenna_positions, sweeps)
    if sweep_times is not None:
        times = np.asarray(sweep_times, dtype=float)
        if times.shape != (sweeps,) or np.any(np.diff(times) <= 0):
            raise ParameterError("raw_from_arrays", "sweep_times",
                                 f"{sweeps} strictly increasing times [s]", times.shape)
        times = times - times[0]
        interval = float(np.median(np.diff(times)))
    else:
        times = np.arange(sweeps, dtype=float)
        interval = 1.0
    if continuous_motion and (sweep_times is None or reference_point is not None
                              or reference_range is not None):
        raise ParameterError("raw_from_arrays", "continuous_motion",
                             "sweep_times and absolute ranges (no reference) for FMCW sweeps",
                             "a reference or no sweep_times")
    if velocities is None:
        velocities = np.gradient(positions, times, axis=0)
    velocities = _vectors("velocities", velocities, sweeps)

    if reference_range is not None:
        ranges = np.asarray(reference_range, dtype=float)
        if ranges.shape != (sweeps,):
            raise ParameterError("raw_from_arrays", "reference_range", f"shape ({sweeps},)",
                                 ranges.shape)
    elif reference_point is not None:
        point = np.asarray(reference_point, dtype=float).reshape(3)
        ranges = np.linalg.norm(positions - point, axis=1)
    else:
        ranges = np.zeros(sweeps)
    if boresight is None:
        if reference_point is not None:
            look = np.asarray(reference_point, dtype=float).reshape(3) - positions
        else:
            look = np.broadcast_to([0.0, 0.0, -1.0], (sweeps, 3))
    else:
        look = np.broadcast_to(np.asarray(boresight, dtype=float), (sweeps, 3))
    look = look / np.linalg.norm(look, axis=1, keepdims=True)

    radar = equivalent_radar(first, step, count, interval)
    rf = first + step * np.arange(count)
    straight = _straightness(positions, velocities, radar)
    product = xr.Dataset(
        {
            "raw": (("sweep", "sample"), data, {"units": "1", "long_name": "recorded samples"}),
            "platform_position": (("sweep", "xyz"), positions, {"units": "m"}),
            "platform_velocity": (("sweep", "xyz"), velocities, {"units": "m/s"}),
            "boresight": (("sweep", "xyz"), np.array(look), {"units": "1"}),
            "attitude": (("sweep", "angle"), np.zeros((sweeps, 3)), {"units": "rad"}),
            "frequency": (("sample",), rf, {"units": "Hz", "long_name": "RF frequency"}),
        },
        coords={"sweep": np.arange(sweeps), "sample": np.arange(count),
                "slow_time": ("sweep", times, {"units": "s"}),
                "fast_time": ("sample", fast_time(radar), {"units": "s"}),
                "xyz": ["x", "y", "z"], "angle": ["heading", "pitch", "roll"]},
    )
    off_nadir = float(np.degrees(np.arccos(np.clip(-look[:, 2].mean(), -1, 1))))
    product.attrs.update(radar.to_attrs())
    product.attrs.update(product="raw", look_off_nadir_deg=off_nadir, look_squint_deg=0.0,
                         rvp=0, mitsar_version=__version__, simulator="recorded",
                         raw_kind="dechirped" if continuous_motion else "frequency_samples",
                         phase_sign=int(phase_sign), trajectory_straight=int(straight),
                         continuous_motion=int(continuous_motion))
    if not continuous_motion:
        product["reference_range"] = (("sweep",), ranges, {
            "units": "m", "long_name": "range the samples are referenced to"})
        if reference_point is not None and reference_range is None:
            product.attrs["reference_point"] = [float(v) for v in np.ravel(reference_point)]
    for key, value in (attrs or {}).items():
        product.attrs[key] = json.dumps(value) if isinstance(value, dict | list) else value
    return product


def _straightness(positions: NDArray, velocities: NDArray, radar: Radar) -> bool:
    """Straight uniform track within lambda/16 (as :func:`mitsar.focus.motion.straight_track`)."""
    index = np.arange(len(positions))
    mean_velocity = velocities.mean(axis=0)
    norm = np.linalg.norm(mean_velocity)
    if not norm > 0:
        return False
    along = mean_velocity / norm
    offset = positions - positions[0]
    coordinate = offset @ along
    fit = np.polyval(np.polyfit(index, coordinate, 1), index)
    error = max(np.abs(coordinate - fit).max(),
                np.linalg.norm(offset - coordinate[:, None] * along, axis=1).max())
    return bool(error <= radar.wavelength / 16)


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------
def _generic_from_mapping(data: dict[str, Any], attrs: dict[str, Any], source: str
                          ) -> xr.Dataset:
    missing = [k for k in ("samples", "frequencies", "antenna_positions") if k not in data]
    if missing:
        raise MitsarError(f"{source}: not a mitsar raw product and not the generic layout: "
                          f"missing {missing} (expected variables {list(GENERIC_KEYS)}; see "
                          "docs/focusing.md)")
    samples = np.asarray(data["samples"])
    if "samples_imag" in data:
        samples = samples + 1j * np.asarray(data["samples_imag"])
    phase_sign = int(np.asarray(attrs.get("phase_sign", data.get("phase_sign", 1))).ravel()[0])
    motion = bool(int(np.asarray(attrs.get("continuous_motion",
                                           data.get("continuous_motion", 0))).ravel()[0]))
    kwargs = {k: np.asarray(data[k]) for k in ("reference_point", "sweep_times",
                                               "reference_range", "velocities", "boresight")
              if k in data}
    return raw_from_arrays(samples, data["frequencies"], data["antenna_positions"],
                           phase_sign=phase_sign, continuous_motion=motion,
                           attrs={"source": source}, **kwargs)


def read_raw(path: str | os.PathLike) -> xr.Dataset:
    """Read recorded (or saved) raw data.

    * a mitsar raw product written by :func:`mitsar.io.save` (``.nc``);
    * the generic layout (``docs/focusing.md``) in netCDF (``.nc``), HDF5 (``.h5``,
      ``.hdf5``) or NumPy (``.npz``): variables ``samples`` (sweep, sample) complex (or
      ``samples`` + ``samples_imag`` real), ``frequencies`` (sample) [Hz],
      ``antenna_positions`` (sweep, 3) [m], optional ``reference_point`` (3),
      ``reference_range`` (sweep), ``sweep_times`` (sweep), ``velocities`` (sweep, 3),
      ``boresight`` (sweep, 3) or (3), and attributes (or scalar variables) ``phase_sign``
      (+1/-1) and ``continuous_motion`` (0/1).

    Raises
    ------
    MitsarError
        For a missing or unreadable file, or one in neither layout.
    """
    path = Path(path)
    if not path.is_file():
        raise MitsarError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        with np.load(path, allow_pickle=False) as handle:
            data = {k: handle[k] for k in handle.files}
        return _generic_from_mapping(data, {}, str(path))
    if suffix in (".h5", ".hdf5", ".he5"):
        import h5py  # optional dependency, loaded for HDF5 files only

        try:
            with h5py.File(path, "r") as handle:
                data = {k: handle[k][()] for k in handle.keys()
                        if isinstance(handle[k], h5py.Dataset)}
                attrs = dict(handle.attrs)
        except OSError as error:
            raise MitsarError(f"{path}: not a readable HDF5 file ({error})") from error
        for key, value in list(data.items()):
            if value.dtype.names and set(value.dtype.names) >= {"r", "i"}:
                data[key] = value["r"] + 1j * value["i"]
        return _generic_from_mapping(data, attrs, str(path))
    try:
        with xr.open_dataset(path, engine="h5netcdf") as handle:
            dataset = handle.load()
    except (OSError, ValueError, TypeError) as error:
        raise MitsarError(f"{path}: not a readable netCDF/HDF5 file ({error})") from error
    if dataset.attrs.get("product") == "raw":
        return dataset
    data = {k: dataset[k].values for k in dataset.variables}
    return _generic_from_mapping(data, dict(dataset.attrs), str(path))


def read_gotcha(folder: str | os.PathLike, pass_number: int = 1, polarisation: str = "HH",
                azimuths: ArrayLike | None = None, autofocus: bool = False) -> xr.Dataset:
    """Read AFRL GOTCHA volumetric SAR phase histories into a referenced raw product.

    Files ``data_3dsar_pass{P}_az{AAA}_{POL}.mat`` (MATLAB v5, struct ``data`` with ``fp``
    (frequency, pulse), ``freq``, ``x``, ``y``, ``z``, ``r0``, ``th``, ``phi``, ``af``).
    The data are ``fp ~ A exp(-j 4 pi f (R - r0) / c)``, motion-compensated to the scene centre
    (the origin): phase sign -1, reference range ``r0``. Frequencies are refitted on a float64
    linear grid (the stored float32 values wobble by ~500 Hz).

    Parameters
    ----------
    folder : path-like
    pass_number : int
    polarisation : str
        "HH", "HV", "VH" or "VV".
    azimuths : array_like of int, optional
        One-degree files to read (default: all present, sorted).
    autofocus : bool
        Apply AFRL's range correction ``af.r_correct`` (added to ``r0``) and phase correction
        ``exp(+j af.ph_correct)``.
    """
    from scipy.io import loadmat  # loaded for GOTCHA files only

    folder = Path(folder)
    if azimuths is None:
        files = sorted(glob.glob(str(folder / f"data_3dsar_pass{pass_number}_az*_"
                                             f"{polarisation}.mat")))
    else:
        files = [str(folder / f"data_3dsar_pass{pass_number}_az{int(a):03d}_{polarisation}.mat")
                 for a in np.ravel(azimuths)]
    if not files or not all(os.path.isfile(f) for f in files):
        raise MitsarError(f"{folder}: no GOTCHA files data_3dsar_pass{pass_number}_az*_"
                          f"{polarisation}.mat (or some requested azimuths are missing)")
    records = [loadmat(f, squeeze_me=True, struct_as_record=False)["data"] for f in files]

    def cat(name: str) -> NDArray[np.float64]:
        return np.concatenate([np.atleast_1d(getattr(r, name)) for r in records]).astype(float)

    samples = np.concatenate([np.asarray(r.fp) for r in records], axis=1).T.astype(complex)
    positions = np.stack([cat("x"), cat("y"), cat("z")], axis=1)
    reference = cat("r0")
    if autofocus:
        reference = reference + np.concatenate(
            [np.atleast_1d(r.af.r_correct) for r in records]).astype(float)
        phase = np.concatenate([np.atleast_1d(r.af.ph_correct) for r in records]).astype(float)
        samples = samples * np.exp(1j * phase)[:, None]
    frequencies = np.asarray(records[0].freq, dtype=float)
    return raw_from_arrays(
        samples, frequencies, positions, phase_sign=-1, reference_range=reference,
        boresight=-positions, attrs={"source": "AFRL GOTCHA volumetric SAR data set v1.0",
                                     "files": [os.path.basename(f) for f in files],
                                     "autofocus": int(autofocus),
                                     "azimuth_deg": [float(cat("th").min()),
                                                     float(cat("th").max())]})
