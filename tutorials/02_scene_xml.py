# %% [markdown]
# # 2. Authoring a scene in XML, with a mesh
#
# A mitsar scene is a Mitsuba 3 XML file whose shapes carry radar materials (the plugins are
# tabulated in [XML plugins](../plugins.md)). It names no sensor and no emitter: the radar, the
# flight and the look are given in Python. Here we write one by hand: a concrete floor, a metal
# box as a PLY mesh (as Blender or any modeller would export it) and a point target; then we
# load it, check it, trace an acquisition and focus it on the floor.

# %%
import math
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import mitsar
from mitsar.focus.grid import PlaneGrid
from mitsar.plots.figures import plot_image
from mitsar.scene import box_mesh, load_scene, scene_point_targets, scene_surfaces, write_ply

QUICK = os.environ.get("MITSAR_TUTORIAL_QUICK") == "1"
folder = Path(tempfile.mkdtemp(prefix="mitsar-tutorial-"))

# %% [markdown]
# ## A mesh
#
# Meshes are PLY or OBJ files in metres, z up, referenced relative to the XML file.
# `mitsar.scene.write_ply` writes one; `box_mesh` makes an axis-aligned box (12 triangles).
# The box stands on the floor, 0.3 m on a side.

# %%
vertices, faces = box_mesh([14.6, 8.2, 0.0], [14.9, 8.5, 0.3])
write_ply(folder / "meshes" / "box.ply", vertices, faces)
print(len(vertices), "vertices,", len(faces), "triangles")

# %% [markdown]
# ## The XML
#
# - the floor is a `rectangle` (2 × 2 m, scaled by `to_world`) with the paper's concrete
#   (`doublelobe` preset `concrete_94ghz_paper`: σ⁰ = −20 dB);
# - the box is the PLY mesh with a mirror-like `doublelobe` (its faces reflect specularly);
#   meshes take `face_normals`, since the radar uses the faces' normals;
# - the point target is a 2 cm sphere with the `pointtarget` material (σ = 1 m²), its centre
#   3 cm above the floor;
# - `$rcs` is a scene parameter, declared by `<default>` and set at load time.

# %%
xml = """<scene version="3.0.0">
    <default name="rcs" value="1.0"/>
    <bsdf type="doublelobe" id="concrete">
        <string name="preset" value="concrete_94ghz_paper"/>
    </bsdf>
    <bsdf type="doublelobe" id="metal">
        <string name="preset" value="mirror"/>
    </bsdf>
    <shape type="rectangle" id="floor">
        <transform name="to_world">
            <scale x="1.0" y="1.0"/>
            <translate x="15.0" y="8.0" z="0.0"/>
        </transform>
        <ref id="concrete"/>
    </shape>
    <shape type="ply" id="box">
        <string name="filename" value="meshes/box.ply"/>
        <boolean name="face_normals" value="true"/>
        <ref id="metal"/>
    </shape>
    <shape type="sphere" id="target">
        <point name="center" x="15.0" y="7.8" z="0.03"/>
        <float name="radius" value="0.02"/>
        <bsdf type="pointtarget"><float name="rcs" value="$rcs"/></bsdf>
    </shape>
</scene>
"""
path = folder / "room.xml"
path.write_text(xml)

# %% [markdown]
# ## Load and check
#
# `load_scene` registers mitsar's plugins, checks every parameter (an unknown one raises a
# `ParameterError` naming the file, element, line and parameter) and returns a Mitsuba scene.
# `scene_surfaces` lists what the radar will see.

# %%
scene = load_scene(path, rcs=0.05)
for surface in scene_surfaces(scene):
    material = surface.material.name if surface.material is not None else "-"
    print(f"{surface.id:8s} {surface.kind:10s} {surface.area:6.3f} m²  material {material}")
for point in scene_point_targets(scene):
    print("point target at", np.round(point.position, 3), "rcs", point.rcs, "m²")

# %% [markdown]
# ## Trace and focus
#
# `simulate_scene` runs the `radar` integrator over the loaded scene: surface scatterers are
# sampled on every radar surface (9 per resolution cell), shadows are traced, and the
# time-of-flight histograms become raw data by one inverse FFT per sweep. `max_depth=2` adds
# paths with one specular reflection (shot as `rays` rays per sweep).
# We focus on a plane grid on the floor (x, y).

# %%
target = np.array([15.0, 8.0, 0.0])
duration = 0.4 if QUICK else 0.8
start = np.array([15.0 - 0.25 * duration, 1.4, 4.5])       # the track passes the target halfway
look = mitsar.Look(math.degrees(math.atan2(target[1] - start[1], start[2])))
trajectory = mitsar.Trajectory.linear(start, [0.5, 0.0, 0.0], duration)
raw = mitsar.simulate_scene(mitsar.Radar(), trajectory, look, scene, max_depth=2,
                            rays=1024 if QUICK else 4096, seed=3)
print(dict(raw.sizes))

step = 0.03 if QUICK else 0.02
grid = PlaneGrid(origin=[15.0, 8.0, 0.0], axis_u=[1, 0, 0], axis_v=[0, 1, 0],
                 u=[-0.8, 0.8, step], v=[-0.8, 0.8, step])
image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1)
ax = plot_image(image, dynamic_range_db=45.0)
ax.set_title("floor, metal box and point target")

# %% [markdown]
# The point target is the bright point at (15.0, 7.8) m (set to 0.05 m² at load time, so that
# the floor shows), with its sidelobes; the floor's speckle, at σ⁰ = −20 dB, fills the
# footprint that the short aperture focuses. The mirror box gives no direct backscatter (a
# mirror has no diffuse lobe): what it does to the echoes goes through reflections, the subject
# of [Multipath](../multipath.md). In a TOML experiment the same scene is
# `scene = "room.xml"` (a path relative to the TOML file), see
# [Experiments](../experiments.md). Next:
# [a real flight](03_real_flight.md).

# %%
peak = np.unravel_index(np.argmax(np.abs(image["image"].values)), image["image"].shape)
print("brightest pixel at", np.round(image["position"].values[peak], 2), "m")
plt.close("all")
