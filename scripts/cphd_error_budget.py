"""Error budget of the stop-and-go CPHD path against the dechirped raw product (docs/products.md,
"The -60 dB aim: error budget and fix").

The test scene of ``tests/test_export.py`` with unit amplitudes (no antenna pattern): each
step's error as 20 log10 of the relative norm, on the same pixels. D1 and D2 are float64 direct
sums (matched filters) of the continuous-motion dechirped model and of the stop-and-go FX model
``exp(-j 2 pi f_n DeltaTOA)``. About 20 s.

Usage: ``python scripts/cphd_error_budget.py``
"""

from __future__ import annotations

import dataclasses

import numpy as np

import mitsar
from mitsar.export import read_cphd, write_cphd
from mitsar.export.phase_history import fx_phase_history
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import dechirped_phase_cycles, fast_time
from mitsar.raw.recorded import raw_from_arrays

TARGET = np.array([15.0, 8.0, 0.0])
GRID = mitsar.grid.SlantGrid(along_track=[-0.3, 0.7, 0.05], slant_range=[7.5, 8.5, 0.05])


def relative_db(a: np.ndarray, b: np.ndarray) -> float:
    return float(20 * np.log10(np.linalg.norm(a - b) / np.linalg.norm(b)))


def referenced(history: object, boresight: np.ndarray) -> object:
    """The stop-and-go vectors as a referenced raw product (``read_cphd(form="referenced")``
    without the file)."""
    count = history.signal.shape[1]
    return raw_from_arrays(
        history.signal, history.first_frequency + history.frequency_step * np.arange(count),
        history.position, sweep_times=history.time, phase_sign=-1,
        reference_range=history.reference_range, velocities=history.velocity,
        boresight=boresight)


def main() -> None:
    radar = mitsar.Radar()
    raw = mitsar.simulate_point_targets(
        radar, mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], 0.4), mitsar.Look(55.7),
        [mitsar.PointTarget(TARGET)], normalized=True, pattern=False)
    original = mitsar.focus(raw, grid=GRID, backend="numpy")
    a = original["image"].values / original["coverage"].values
    pixels = original["position"].values.reshape(-1, 3)
    boresight = raw["boresight"].values
    t = fast_time(radar)
    positions, velocities = raw["platform_position"].values, raw["platform_velocity"].values
    samples = raw["raw"].values
    rf = radar.carrier_frequency + radar.chirp_rate * t
    d1 = np.zeros(len(pixels), complex)
    d2 = np.zeros(len(pixels), complex)
    for k in range(len(positions)):  # a diagnostic, not a hot path
        antenna = positions[k] + velocities[k] * t[:, None]
        delay = 2 * np.linalg.norm(pixels[:, None] - antenna[None], axis=-1) / SPEED_OF_LIGHT
        cycles = dechirped_phase_cycles(delay, t[None], radar)
        d1 += (samples[k] * np.exp(-2j * np.pi * (cycles - np.floor(cycles)))).sum(axis=1)
        offset = np.linalg.norm(pixels - positions[k], axis=1) - np.linalg.norm(
            TARGET - positions[k])
        d2 += np.exp(-2j * np.pi * rf[None] * 2 * offset[:, None] / SPEED_OF_LIGHT).sum(axis=1)
    d1 = d1.reshape(a.shape) / samples.size
    d2 = d2.reshape(a.shape) / samples.size
    print(f"D1 (dechirped) vs D2 (stop-and-go), ideal images: {relative_db(d1, d2):6.1f} dB")
    print(f"BPA of the raw product vs D1:                    {relative_db(a, d1):6.1f} dB")
    history = fx_phase_history(raw, TARGET, "none")
    delay = 2 * (np.linalg.norm(history.position - TARGET, axis=1)
                 - history.reference_range) / SPEED_OF_LIGHT
    model = np.exp(-2j * np.pi * rf[None] * delay[:, None])
    closed = mitsar.focus(referenced(dataclasses.replace(history, signal=model), boresight),
                          grid=GRID)["image"].values
    print(f"referenced BP of the closed-form FX vs D2:       {relative_db(closed, d2):6.1f} dB")
    for motion in ("exact", "srp", "none"):
        history = fx_phase_history(raw, TARGET, motion)
        per_sweep = (np.linalg.norm(history.signal - model, axis=1)
                     / np.linalg.norm(model, axis=1))
        image = mitsar.focus(referenced(history, boresight), grid=GRID)["image"].values
        print(f"{motion:>5}: FX vs closed form {relative_db(history.signal, model):6.1f} dB "
              f"(first/middle sweep {20 * np.log10(per_sweep[0]):6.1f} / "
              f"{20 * np.log10(per_sweep[len(per_sweep) // 2]):6.1f} dB); referenced BP vs "
              f"BPA {relative_db(image, a):6.1f} dB")
    path = write_cphd(raw, "/tmp/mitsar_cphd_error_budget.cphd", srp=TARGET, overwrite=True)
    back = mitsar.focus(read_cphd(path), grid=GRID, backend="numpy")
    b = back["image"].values / back["coverage"].values
    print(f"read_cphd (dechirped) then BPA vs BPA:           {relative_db(b, a):6.1f} dB")


if __name__ == "__main__":
    main()
