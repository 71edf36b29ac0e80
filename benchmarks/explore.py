"""How long `jaxroll.explore()` takes to redraw when a slider moves (issue 35, item 6: under a second after the first
compilation), and its Monte Carlo button.

The redraw is `explore_curves` (one `theory_summary` program per ticked theory) plus the figure; this script times
`explore_curves` for a run of slider moves, as the widget calls it, and — where ipywidgets is installed — the
widget's own `Explorer.redraw()` (matplotlib included) for the same moves. First calls compile (oblique headings
and the moment method compile once more: other static shapes); every later call only runs.

Usage: python benchmarks/explore.py [--theories envelope_fpk[,roberts,esam,moment]] [--mc 200] [--no-widget]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import jax


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--theories", default="envelope_fpk")
    parser.add_argument("--mc", type=int, default=200, help="Monte Carlo trials of the button (0: skip)")
    parser.add_argument("--no-widget", action="store_true")
    args = parser.parse_args()
    import jaxroll

    if hasattr(jaxroll, "configure"):
        jaxroll.configure()
    from jaxroll.notebook import explore_curves, explore_monte_carlo

    theories = tuple(args.theories.split(","))
    print(
        f"device={jax.devices()[0].device_kind} x{len(jax.devices())}, cores available "
        f"{len(os.sched_getaffinity(0))}, theories {','.join(theories)}; load average {os.getloadavg()[0]:.1f}"
    )
    moves = (
        [dict(hs=h) for h in (6.0, 6.5, 7.5, 8.0, 5.5)]
        + [dict(t01=t) for t in (9.5, 11.0)]
        + [dict(gm_correction=r) for r in (0.8, 0.9, 1.2)]
        + [dict(speed=u) for u in (1.0, 2.0)]
    )
    oblique = [dict(heading_deg=h) for h in (150.0, 135.0, 165.0)]
    t0 = time.perf_counter()
    explore_curves(theories=theories)
    print(f"first call (compilation + run): {time.perf_counter() - t0:.2f} s")

    def run(sequence, label):
        values = dict(hs=7.0, t01=10.0, heading_deg=180.0, speed=0.0, gm_correction=1.0)
        times = []
        for change in sequence:
            values.update(change)
            t = time.perf_counter()
            explore_curves(theories=theories, **values)
            times.append(time.perf_counter() - t)
        print(
            f"{label}: {len(times)} slider moves, median {statistics.median(times):.3f} s, max {max(times):.3f} s "
            f"(each: {', '.join(f'{x:.3f}' for x in times)})"
        )
        return values

    run(moves, "explore_curves, head seas")
    run(oblique, "explore_curves, oblique seas (the first one compiles)")
    run(oblique, "explore_curves, oblique seas again")
    if not args.no_widget:
        try:
            import ipywidgets  # noqa: F401
        except ImportError:
            print("ipywidgets not installed: the widget's redraw (matplotlib included) not timed")
        else:
            from jaxroll.notebook import Explorer

            ex = Explorer(theories=theories)
            times = []
            for change in moves:
                for name, value in change.items():
                    ex.sliders[
                        name
                    ].unobserve_all()  # set the value without the callback, then time the callback
                    ex.sliders[name].value = value
                times.append(ex.redraw())
            print(
                f"Explorer.redraw (theories + figure): median {statistics.median(times):.3f} s, max "
                f"{max(times):.3f} s"
            )
    if args.mc:
        for label in ("first (compilation + run)", "second"):
            t = time.perf_counter()
            stats = explore_monte_carlo(num_realizations=args.mc, duration=1800.0, discard=300.0)
            print(
                f"Monte Carlo button, {args.mc} x 1800 s, {label}: {time.perf_counter() - t:.2f} s "
                f"({stats.n_capsized} capsized)"
            )


if __name__ == "__main__":
    main()
