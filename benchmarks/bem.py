"""Benchmark: the BEM wave moment of a 3 000-panel hull, 40 frequencies × 7 headings (issue 44, target ≤ 2 min).

`jaxroll.ship.bem_roll_coefficients` on the C11-like hull (`jaxroll/data/c11_hull.toml`) with the defaults of
`jaxroll hydrostatics c11 --wave-moment bem`: 40 frequencies up to 1.60 rad/s (where the incident pressure at the keel
is 5 %), panels of at most 0.95 λ/6 of it (3.82 m: 3 470 panels, the longest edge 3.89 m), 7 headings: 41 radiation
problems (roll) + 40 × 7 diffraction problems, solved by capytaine (`pip install "jaxroll[bem]"`). `--panel-size M`
panels it at M and solves up to the highest frequency those panels allow (λ/6 ≥ the longest edge; 4.6 m: 3 326
panels, 1.62 rad/s). Prints `name=value` lines: the panels, capytaine's wall time apart from the whole call's
(meshing, the checks, jaxroll's Froude–Krylov moment), and the load average before and after (the machine is shared:
say it with the figure).

Run: `python benchmarks/bem.py [--panel-size M] [--frequencies 40] [--headings 7] [--lid]`.
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

import jaxroll
from jaxroll.ship import (
    bem_frequencies,
    bem_mesh,
    bem_roll_coefficients,
    c11_hull,
    c11_hull_loading,
    equilibrium,
)
from jaxroll.ship._bem_mesh import PANELS_PER_WAVELENGTH
from jaxroll.ship._hydrostatics import GRAVITY


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--panel-size", type=float, default=None)
    ap.add_argument("--frequencies", type=int, default=40)
    ap.add_argument("--headings", type=int, default=7)
    ap.add_argument("--lid", action="store_true")
    args = ap.parse_args()
    jaxroll.configure()
    hull, loading = c11_hull(), c11_hull_loading()
    eq = equilibrium(hull, loading)
    omega = bem_frequencies(float(eq.sinkage), args.frequencies)
    if args.panel_size is not None:
        mesh = bem_mesh(
            hull, loading, sinkage=float(eq.sinkage), trim=float(eq.trim), panel_size=args.panel_size
        )
        top = math.sqrt(2 * math.pi * GRAVITY / (PANELS_PER_WAVELENGTH * mesh.panel_size))
        omega = bem_frequencies(float(eq.sinkage), args.frequencies, math.floor(top * 100) / 100)
    headings = np.linspace(0.0, math.pi, args.headings)
    print(f"load_before={os.getloadavg()[0]:.2f}")
    start = time.perf_counter()
    c = bem_roll_coefficients(
        hull, loading, omega=omega, headings=headings, panel_size=args.panel_size, lid=args.lid
    )
    total = time.perf_counter() - start
    print(f"load_after={os.getloadavg()[0]:.2f}")
    print(f"panels={c.n_panels} panel_size_m={c.panel_size:.3f} lid={c.lid}")
    print(f"frequencies={omega.size} omega_max_rad_s={omega[-1]:.3f} headings={headings.size}")
    print(f"problems={omega.size + 1 + omega.size * headings.size}")
    print(f"capytaine_s={c.solver_seconds:.1f} jaxroll_s={total - c.solver_seconds:.1f} total_s={total:.1f}")
    w0 = 2 * math.pi / 24.4
    print(f"A44(omega0)_kg_m2={np.interp(w0, c.omega, c.added_inertia):.4e}")
    print(f"B44(omega0)_N_m_s={np.interp(w0, c.omega, c.radiation_damping):.4e}")


if __name__ == "__main__":
    main()
