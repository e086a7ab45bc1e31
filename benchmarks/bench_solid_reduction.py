"""The Craig–Bampton convergence study of issue 23: the 49,980-DOF solid block of
:func:`vibroimpact.benchmarks.large_models.solid_model` (generated, nothing committed)
reduced to its gap DOF plus 50, 100 and 200 fixed-interface modes, each against the full
model from the same initial state (:func:`~vibroimpact.benchmarks.large_models.
solid_reduction_benchmark`). ``--time-error`` adds each model's own error of time
discretisation (against dt / 4); ``--elements 40,6,6`` takes a smaller block. Results and
their reading: ``benchmarks/solid-reduction.md``. Run with
``python benchmarks/bench_solid_reduction.py [N_MODES ...] [--steps N] [--dt DT]
[--elements EX,EY,EZ] [--time-error] [--json]``."""

from __future__ import annotations

import argparse
import json

from vibroimpact.benchmarks.large_models import solid_reduction_benchmark

if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("n_modes", nargs="*", type=int, default=[50, 100, 200])
    p.add_argument("--steps", type=int, default=500)
    p.add_argument("--dt", type=float, default=1e-6)
    p.add_argument("--elements", default="85,13,13")
    p.add_argument("--time-error", action="store_true")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    elements = tuple(int(e) for e in args.elements.split(","))
    if not args.json:
        print("modes  f_max kHz  outside  disp err  force err  peak err  time err full/red  "
              "reduction s  full run s  cost")
    for n in args.n_modes:
        row = solid_reduction_benchmark(steps=args.steps, n_modes=n, dt=args.dt,
                                        n_elements=elements,  # type: ignore[arg-type]
                                        time_error=args.time_error)
        if args.json:
            print(json.dumps(row), flush=True)
            continue
        times = (f"{row['full_time_error']:.1e}/{row['reduced_time_error']:.1e}"
                 if args.time_error else "-")
        print(f"{n:5d}  {row['max_interior_hz'] / 1e3:9.1f}  {row['outside_fraction']:7.1%}  "
              f"{row['displacement_error']:8.1e}  {row['force_error']:9.1e}  "
              f"{row['peak_force_error']:8.1e}  {times:>18s}  {row['reduction_s']:11.1f}  "
              f"{row['full_run_s']:10.1f}  {row['cost_fraction']:.2f}", flush=True)
