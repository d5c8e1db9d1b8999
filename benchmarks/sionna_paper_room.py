"""Sionna RT timing of one aperture position in the paper's room (run by ``bench_speed.py``).

Needs Sionna RT (``pip install sionna-rt==2.2.0``, which pins Mitsuba 3.9.1 and Dr.Jit 1.5.0:
the versions mitsar is tested with). Imports nothing of mitsar, so it can run under another
interpreter (``--sionna-python`` of ``bench_speed.py``). Prints one JSON line.

Workload, per aperture position: the room of the canned ``control_volume`` (paper Table 3:
[0, 30] x [0, 10] x [0, 6] m, six concrete rectangles, here ITU concrete with scattering
coefficient 1, Lambertian) at 94 GHz, a transmitter and a receiver 1 cm below it at the antenna
position of the mitsar benchmark's track (isotropic patterns: the pattern does not change the
ray work), and ``PathSolver(max_depth=1, los=False,
specular_reflection=False, diffuse_reflection=True, refraction=False)`` — direct
backscatter only. Its ``samples_per_src`` rays leave over the whole sphere; by default 10^6,
which puts as many rays into mitsar's culling window (±2 beamwidths in both direction sines,
~6 % of the sphere) as mitsar has contributions per sweep at the default density. Each
position moves both radios (a scene edit) and solves; the timing reads the path coefficients
back (Dr.Jit is asynchronous) and is taken after one warm-up solve (kernel compilation).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

WALLS = (  # id, scale x y, rotation, translation: as scenes/control_volume.xml
    ("floor", (15, 5), "", (15, 5, 0)),
    ("ceiling", (15, 5), '<rotate x="1" angle="180"/>', (15, 5, 6)),
    ("wall_y0", (15, 3), '<rotate x="1" angle="-90"/>', (15, 0, 3)),
    ("wall_y10", (15, 3), '<rotate x="1" angle="90"/>', (15, 10, 3)),
    ("wall_x0", (3, 5), '<rotate y="1" angle="90"/>', (0, 5, 3)),
    ("wall_x30", (3, 5), '<rotate y="1" angle="-90"/>', (30, 5, 3)),
)


def room_xml() -> str:
    """The paper's room in Sionna RT's XML dialect."""
    shapes = "".join(
        f'<shape type="rectangle" id="{name}"><transform name="to_world">'
        f'<scale x="{sx}" y="{sy}"/>{rot}<translate x="{tx}" y="{ty}" z="{tz}"/></transform>'
        '<ref id="concrete"/></shape>'
        for name, (sx, sy), rot, (tx, ty, tz) in WALLS)
    return ('<scene version="2.1.0"><bsdf type="itu-radio-material" id="concrete">'
            '<string name="type" value="concrete"/><float name="thickness" value="0.2"/>'
            '<float name="scattering_coefficient" value="1.0"/></bsdf>'
            f'{shapes}</scene>')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--positions", type=int, default=4, help="timed aperture positions")
    parser.add_argument("--samples", type=int, default=10**6, help="samples_per_src")
    parser.add_argument("--start", default="14.8,1.4,4.5")
    parser.add_argument("--step", type=float, default=0.002, help="x step per position [m]")
    args = parser.parse_args()

    import drjit as dr  # lazy: Sionna RT's stack is only needed here
    import sionna.rt as rt  # lazy: --help works without Sionna RT

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "room.xml"
        path.write_text(room_xml())
        scene = rt.load_scene(str(path), merge_shapes=False)
    scene.frequency = 94e9
    scene.tx_array = rt.PlanarArray(num_rows=1, num_cols=1, pattern="iso", polarization="V")
    scene.rx_array = rt.PlanarArray(num_rows=1, num_cols=1, pattern="iso", polarization="V")
    start = [float(v) for v in args.start.split(",")]
    # Isotropic radios: Sionna RT shoots its rays over the whole sphere whatever the pattern,
    # so the ray work per position does not depend on the antenna (orientation left default).
    tx = rt.Transmitter("tx", position=start)
    rx = rt.Receiver("rx", position=[start[0], start[1], start[2] - 0.01])
    scene.add(tx)
    scene.add(rx)
    solver = rt.PathSolver()

    def solve(i: int) -> int:
        x = start[0] + i * args.step
        tx.position = [x, start[1], start[2]]
        rx.position = [x, start[1], start[2] - 0.01]
        paths = solver(scene, max_depth=1, los=False, specular_reflection=False,
                       diffuse_reflection=True, refraction=False,
                       samples_per_src=args.samples, synthetic_array=True)
        a_re, _ = paths.a
        valid = paths.valid
        dr.eval(a_re, valid)
        return int(dr.count(valid.array)[0]) if hasattr(valid, "array") else 0

    begin = time.perf_counter()
    solve(0)  # warm-up: compilation
    cold = time.perf_counter() - begin
    times, counts = [], []
    for i in range(1, args.positions + 1):
        begin = time.perf_counter()
        counts.append(solve(i))
        times.append(time.perf_counter() - begin)
    print(json.dumps({"seconds_per_position": min(times), "median_seconds": sorted(times)[
        len(times) // 2], "cold_seconds": cold, "samples_per_src": args.samples,
        "paths": counts[-1], "positions": args.positions}))


if __name__ == "__main__":
    main()
