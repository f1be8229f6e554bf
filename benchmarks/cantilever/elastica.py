"""The cantilever bent by its own weight: the inextensible elastica, plane strain.

usage: elastica.py [E_PA ...]      (default: 1e6, the scene cantilever_large_deflection.json)

Free length L = 0.5 m, thickness t = 0.05 m, rho_s = 1000, nu = 0.3 (benchmarks.md
cantilever): a uniform dead load q = rho_s g t per unit length, bending stiffness
E' t^3 / 12 with E' = E / (1 - nu^2) (the 2-D solids are plane strain). The angle theta(s)
from the horizontal solves theta' = M(s) / (E' I), M(s) = int_s^L q (x(s') - x(s)) ds',
theta(0) = 0, by a damped fixed-point iteration on theta. Printed: the tip's displacement
(dx, dy) and its angle, and the small-deflection dy = q L^4 / (8 E' I) for comparison.
"""
import math
import sys

import numpy as np

RHO, G, NU, LENGTH, THICKNESS = 1000.0, 9.81, 0.3, 0.5, 0.05


def tip(youngs: float, segments: int = 800) -> tuple[float, float, float]:
    """(dx, dy, angle in radians) of the tip under the beam's own weight."""
    stiffness = youngs / (1 - NU**2) * THICKNESS**3 / 12
    load = RHO * G * THICKNESS
    ds = LENGTH / segments
    weight = np.full(segments + 1, ds)
    weight[0] = weight[-1] = ds / 2

    def integrate(f: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * ds)])

    angle = np.zeros(segments + 1)
    for _ in range(20000):
        x = integrate(np.cos(angle))
        y = -integrate(np.sin(angle))
        moment = np.array([np.sum(weight[i:] * load * (x[i:] - x[i])) for i in range(segments + 1)])
        updated = integrate(moment / stiffness)
        if np.max(np.abs(updated - angle)) < 1e-13:
            return x[-1] - LENGTH, y[-1], angle[-1]
        angle = 0.5 * angle + 0.5 * updated
    raise RuntimeError("the elastica iteration did not converge (the load bends the beam past its clamp)")


if __name__ == "__main__":
    for value in [float(v) for v in sys.argv[1:]] or [1e6]:
        dx, dy, angle = tip(value)
        small = RHO * G * THICKNESS * LENGTH**4 / (8 * value / (1 - NU**2) * THICKNESS**3 / 12)
        print(f"E = {value:g} Pa: tip dx {dx:.4f} m, dy {dy:.4f} m, angle {math.degrees(angle):.1f} deg "
              f"(small deflection: dy {-small:.4f} m)")
