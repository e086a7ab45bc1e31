"""The Craig–Bampton convergence study of issue 23: the 49,980-DOF solid block of
:func:`vibroimpact.benchmarks.large_models.solid_patch_model` (generated, nothing committed:
a contact patch of 12 nodes on the top face at the free end) reduced to its patch DOFs plus
50, 100 and 200 fixed-interface modes, each against one full run from the same initial state
(:func:`~vibroimpact.benchmarks.large_models.solid_reduction_benchmark`). ``--select
frequency interface-mass`` chooses the modes both ways (the lowest; those with the most
effective interface mass among ``--candidates``, default 4 × the modes). ``--time-error``
adds the full model's own error of time discretisation (against dt / 2); ``--elements
40,6,6`` takes a smaller block. Results and their reading: ``benchmarks/solid-reduction.md``.
Run with ``python benchmarks/bench_solid_reduction.py [N_MODES ...] [--steps N] [--dt DT]
[--elements EX,EY,EZ] [--select HOW ...] [--candidates N] [--time-error] [--json]``."""

from __future__ import annotations

import argparse
import json

from vibroimpact.benchmarks.large_models import solid_reduction_benchmark

if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("n_modes", nargs="*", type=int, default=[50, 100, 200])
    p.add_argument("--steps", type=int, default=2000)
    p.add_argument("--dt", type=float, default=5e-7)
    p.add_argument("--elements", default="85,13,13")
    p.add_argument("--select", nargs="+", default=["frequency"],
                   choices=["frequency", "interface-mass"])
    p.add_argument("--candidates", type=int, default=None)
    p.add_argument("--time-error", action="store_true")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    elements = tuple(int(e) for e in args.elements.split(","))
    rows = solid_reduction_benchmark(steps=args.steps, n_modes=args.n_modes, dt=args.dt,
                                     n_elements=elements,  # type: ignore[arg-type]
                                     time_error=args.time_error, select=args.select,
                                     candidates=args.candidates)
    if not args.json:
        print("select          of  modes  f_max kHz  disp err  in contact  force err  "
              "impacts full/red  reduction s  reduced run s  full run s  cost")
    for row in rows:
        if args.json:
            print(json.dumps(row), flush=True)
        elif "full_time_error" in row:
            print(f"full model's own time error at dt = {row['dt']:g} s (against dt / 2): "
                  f"{row['full_time_error']:.1e}", flush=True)
        else:
            print(f"{row['select']:14s} {row['candidates']:3d}  "
                  f"{row['n_modes']:5d}  {row['max_interior_hz'] / 1e3:9.1f}  "
                  f"{row['displacement_error']:8.1e}  {row['contact_displacement_error']:10.1e}  "
                  f"{row['force_error']:9.1e}  "
                  f"{row['impacts']:>10d}/{row['impacts_reduced']:<5d}  "
                  f"{row['reduction_s']:11.1f}  {row['reduced_run_s']:13.3f}  "
                  f"{row['full_run_s']:10.1f}  {row['cost_fraction']:.3f}", flush=True)
