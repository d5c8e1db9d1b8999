# %% [markdown]
# # 3. A real flight: navigation errors and autofocus
#
# A drone does not fly the line its navigation system records. mitsar simulates the echoes
# from the **true** track and records the **navigation** track in the product, with the truth
# kept beside it ([Navigation errors](../navigation.md)). Focusing on the recorded track leaves
# a phase error of several radians at 94 GHz (λ = 3.2 mm): the image defocuses. Autofocus
# (phase-gradient autofocus, PGA, or minimum entropy) estimates the error from the image itself
# ([Autofocus](../autofocus.md)).

# %%
import math
import os

import matplotlib.pyplot as plt
import numpy as np

import mitsar
from mitsar.focus.grid import SlantGrid, equivalent_position
from mitsar.plots import navigation as navigation_plots
from mitsar.plots.figures import plot_image

QUICK = os.environ.get("MITSAR_TUTORIAL_QUICK") == "1"

# %% [markdown]
# ## The errors
#
# `NavigationErrors` draws seeded errors of the recorded track: here a random walk of
# 2 mm/√s across the track and 1 mm/√s vertically, and a 1.5 mm vibration at 7 Hz
# (`Vibration(amplitude, frequency, phase)`). Offsets, biases, Gauss–Markov noise and a lever
# arm are also available.

# %%
errors = mitsar.NavigationErrors(
    seed=11, position_random_walk=(0.0, 2e-3, 1e-3),
    vibration=(mitsar.Vibration((0.0, 1.5e-3, 0.0), 7.0, 0.5),))
target = np.array([15.0, 8.0, 0.0])
duration = 0.6 if QUICK else 0.8
start = np.array([15.0 - 0.25 * duration - 0.1, 1.4, 4.5])
track = mitsar.Trajectory.linear(start, [0.5, 0.0, 0.0], duration)
look = mitsar.Look(math.degrees(math.atan2(target[1] - start[1], start[2])))
raw = mitsar.simulate_point_targets(mitsar.Radar(), track, look, [mitsar.PointTarget(target)],
                                    normalized=True, navigation=errors)
navigation_plots.plot_tracks(raw)

# %% [markdown]
# The left panel is the plan view of both tracks; the right one their difference: millimetres,
# i.e. radians of two-way phase.

# %%
phase = navigation_plots.navigation_phase(raw, target)
print(f"phase error at the target: {np.ptp(phase):.1f} rad peak to peak")

# %% [markdown]
# ## Focus without and with autofocus
#
# `focus(..., autofocus="pga" | "entropy")` estimates a phase per sweep and refocuses. The
# product records the estimate (`autofocus_phase`).

# %%
step = 0.02 if QUICK else 0.01
grid = SlantGrid(along_track=[-0.5, 1.0, step], slant_range=[7.3, 8.7, step])
images = {}
for method in (None, "pga", "entropy"):
    images[method or "no autofocus"] = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1,
                                                    autofocus=method)
figure, axes = plt.subplots(1, 3, figsize=(13, 4), layout="constrained")
for ax, (name, image) in zip(axes, images.items(), strict=True):
    plot_image(image, ax=ax, dynamic_range_db=40.0)
    ax.set_title(name)

# %% [markdown]
# ## What autofocus recovered
#
# The impulse response of each image, and the estimated phases against the injected one
# (each detrended: a constant and a linear phase only shift the image).

# %%
results = {}
for name, image in images.items():
    measured = mitsar.measure_impulse_response(image, equivalent_position(image, target))
    results[name] = measured
    print(f"{name:13s} peak {measured['peak_db']:6.2f} dB   azimuth IRW "
          f"{measured['azimuth']['irw_cells']:.2f} cells, PSLR "
          f"{measured['azimuth']['pslr_db']:6.1f} dB")
estimates = {name: image["autofocus_phase"].values for name, image in images.items()
             if "autofocus_phase" in image}
navigation_plots.plot_phase(raw, target, estimates)

# %% [markdown]
# The table says how much of the peak and of the azimuth response each method recovers on
# this flight (on the reduced sizes of `MITSAR_TUTORIAL_QUICK=1` the short aperture leaves
# minimum entropy little to work with). The script
# `examples/real_flight.py` adds the oracle correction and the ray-traced room; its figures are
# in the [gallery](../gallery.md). Next: [materials and multipath](04_materials_multipath.md).

# %%
assert results["pga"]["peak_db"] > results["no autofocus"]["peak_db"]
plt.close("all")
