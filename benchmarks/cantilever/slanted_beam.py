"""The cantilever of cantilever.json built stress-free at an angle to the grid.

usage: slanted_beam.py ANGLE_DEG OUT.json
       iqmpm run OUT.json -o RUN [--set particles_per_axis=4]

A polygon beam (free length 0.5 m, thickness 0.05 m, 0.05 m more held) and a polygon clamp
whose edge is square to the beam, the root at (0.25, 0.75) m in a 1 m box, dx 0.0125,
dt_max 1 ms, 2 s. Probes `tip_dx`, `tip_dy` at the tip's centre: the sag normal to the beam
is tip_dx n_x + tip_dy n_y, n = (sin a, cos a) for a beam pointing down at a degrees; beam
theory gives 3.386 mm x cos(a) (benchmarks.md cantilever). Found a beam across the grid
too soft at 2 particles per axis with the weak solid nodes free (the default); add
`--set solid_weak_nodes=extended` for the extended B-splines (docs/method.md#weak-solid-nodes).
The clamp's node staircase and, at 45 deg, the seeding's staircase stay in the sag.
"""
import json
import math
import sys


def scene(angle_deg: float) -> dict:
    a = math.radians(-angle_deg)
    along, normal = (math.cos(a), math.sin(a)), (-math.sin(a), math.cos(a))
    root = (0.25, 0.75)

    def point(s: float, w: float) -> list[float]:
        return [root[0] + s * along[0] + w * normal[0], root[1] + s * along[1] + w * normal[1]]

    def quad(s0: float, s1: float, w: float) -> list[float]:
        return [*point(s0, -w), *point(s1, -w), *point(s1, w), *point(s0, w)]

    tip = point(0.5, 0.0)
    return {
        "name": f"slanted_beam_{angle_deg:g}",
        "description": f"cantilever.json's beam at {angle_deg:g} deg to the grid (benchmarks/cantilever/slanted_beam.py)",
        "dim": 2, "domain": {"min": [0, 0], "max": [1, 1]}, "dx": 0.0125, "end_time": 2.0, "dt_max": 0.001,
        "solids": [{"name": "beam", "model": "fixed_corotated", "density": 1000, "youngs_modulus": 1e8,
                    "poisson_ratio": 0.3, "shapes": [{"type": "polygon", "vertices": quad(-0.05, 0.5, 0.025)}],
                    "clamps": [{"type": "polygon", "vertices": quad(-0.3, 0.0, 0.3)}]}],
        "probes": [{"type": "displacement", "name": "tip_dx", "point": tip, "axis": 0},
                   {"type": "displacement", "name": "tip_dy", "point": tip, "axis": 1}],
    }


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with open(sys.argv[2], "w") as out:
        json.dump(scene(float(sys.argv[1])), out, indent=1)
