"""``vibroimpact bench``: how fast we are, against peers run in this same process; its flags
and its work. The command line names the command and hands its arguments to :func:`main`."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence

from vibroimpact.benchmarks.sdof import (
    adaptive_benchmark,
    floor_benchmark,
    integrator_table,
    sdof_benchmark,
)

TARGET_S = 1e-3
PAPER_MATLAB_S = 1.3


def build_parser() -> argparse.ArgumentParser:
    """The flags of ``vibroimpact bench``."""
    p = argparse.ArgumentParser(
        prog="vibroimpact bench",
        description=(
            "Times the paper's SDOF case (0.02 s at dt = 1 us, 20,000 steps) with the Hertz and "
            "Lankarani-Nikravesh laws through the Python API (median of --repeats runs) and "
            "SciPy solve_ivp DOP853 with contact events (rtol 1e-8) in the same process."
        ),
    )
    p.add_argument("--repeats", type=int, default=20, help="timed runs per case (default 20)")
    p.add_argument("--quick", action="store_true", help="fewer repeats, for a smoke test")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.add_argument("--sweep-points", type=int, default=None, metavar="N",
                   help="sweep rows (text output): N frequencies x 300 periods of the impact "
                   "oscillator, in-process on 1 and 2 threads and on Dask (default 400, 40 "
                   "with --quick; 0 skips them; JSON: python benchmarks/bench_sweep.py)")
    p.add_argument("--large", action="store_true",
                   help="also the Craig-Bampton rows of the 49,980-DOF solid against a stop "
                   "over a contact patch (its 12 patch DOFs + 50 modes, the lowest and those "
                   "of the most interface mass of 200, against the full model over 2,000 "
                   "steps of 0.5 us: minutes, most of them the full run)")
    p.add_argument("--peers", action="store_true",
                   help="instead: the side-by-side table against SciPy solve_ivp, OpenSeesPy and "
                   "Exudyn at our dt, the paper's SDOF case at equal accuracy (each tool at the "
                   "loosest dt or rtol of its ladder within 1e-7 m / 1e-8 s) and issue 20's "
                   "targets, in one run (pip install '.[peers]'; a missing peer gives one line "
                   "and 'not available' rows)")
    p.add_argument("--peer-repeats", type=int, default=5, metavar="N",
                   help="with --peers: timed runs per peer (median; default and minimum 5; 1 "
                   "with --quick)")
    p.add_argument("--write", metavar="FILE.md", default=None,
                   help="with --peers: also write the tables and the machine to FILE.md and "
                   "the figure of error against wall time to equal-accuracy.png beside it")
    p.add_argument("--readme", metavar="README.md", default=None,
                   help="with --peers: also replace the generated peer table (between "
                   "<!-- bench-peers:start --> and <!-- bench-peers:end -->) in README.md")
    return p


def main(argv: Sequence[str]) -> int:
    """Run ``vibroimpact bench`` with its arguments ``argv``."""
    args = build_parser().parse_args(argv)
    if args.peers:
        from vibroimpact.benchmarks.peers.table import cli_main

        if not args.quick and args.peer_repeats < 5:
            raise SystemExit(f"--peer-repeats: expected at least 5 (medians of at least 5 runs), "
                             f"got {args.peer_repeats}")
        return cli_main(quick=args.quick, repeats=None if args.quick else args.peer_repeats,
                        write=args.write, as_json=args.json, readme=args.readme)
    repeats = 3 if args.quick else max(1, args.repeats)
    rows = sdof_benchmark(repeats=repeats, peer_repeats=1 if args.quick else 5)
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{'case':28s} {'median':>10s} {'steps/s':>12s} {'SciPy DOP853':>13s} {'ratio':>7s}")
    for r in rows:
        print(
            f"{r['problem'] + ' ' + r['law']:28s} {r['median_s'] * 1e3:8.3f} ms "
            f"{r['steps_per_s']:12.3e} {r['scipy_dop853_s'] * 1e3:10.2f} ms "
            f"{r['speedup_vs_scipy']:6.1f}x"
        )
    print(f"target: <= {TARGET_S * 1e3:.0f} ms per run; the paper's MATLAB Newmark: "
          f"{PAPER_MATLAB_S} s")
    f = floor_benchmark(repeats=repeats)
    print(f"floor: the same Newmark steps as a bare Rust loop (x, v, a, force kept): "
          f"{f['floor_s'] * 1e3:.3f} ms; ours / floor {f['ratio']:.2f}x wall time, "
          f"{f['cpu_ratio']:.2f}x CPU time ({f['ours_cpu_s'] * 1e3:.3f} / "
          f"{f['floor_cpu_s'] * 1e3:.3f} ms); target <= {f['target_ratio']}x; histories "
          f"within {f['max_displacement_difference_m']:.1e} m")
    print()
    print("Integrators (paper Table 3): SDOF case, Lankarani-Nikravesh, 0.02 s at dt = 1 us")
    print(f"{'method':32s} {'median':>10s} {'vs Newmark':>11s} {'paper (MATLAB)':>15s} "
          f"{'paper ratio':>12s}")
    table = integrator_table(repeats=repeats)
    for r in table:
        paper = "" if r["paper_s"] is None else f"{r['paper_s']:.1f} s"
        paper_ratio = ("" if r["paper_ratio_to_newmark"] is None
                       else f"{r['paper_ratio_to_newmark']:.1f}x")
        print(f"{r['label']:32s} {r['median_s'] * 1e3:8.3f} ms {r['ratio_to_newmark']:10.2f}x "
              f"{paper:>15s} {paper_ratio:>12s}")
    ratio = {r["method"]: r["ratio_to_newmark"] for r in table}
    print("targets (issue 20): " + "; ".join(
        f"{name} / Newmark {ratio[key]:.2f}x, <= {goal}x: "
        f"{'met' if ratio[key] <= goal else 'MISSED'}"
        for key, name, goal in (("generalized-alpha", "generalized-alpha", 1.3),
                                ("precise", "precise", 1.5))) + " (paper: 19x for precise)")
    print()
    print("Adaptive stepping with located events: SDOF case, 0.02 s (target: 1e-08 m / "
          "1e-09 s in 0.2 ms)")
    for a in adaptive_benchmark(repeats=repeats):
        print(f"{a['method']:18s} rtol {a['tolerance']['rtol']:g}: "
              f"{a['median_s'] * 1e3:.3f} ms (core {a['core_median_s'] * 1e3:.3f} ms), "
              f"{a['steps']} steps + {a['rejected_steps']} discarded; peak error "
              f"{a['peak_error_m']:.1e} m, impact times {a['impact_time_error_s']:.1e} s; "
              f"SciPy DOP853 with events {a['scipy_dop853_s'] * 1e3:.1f} ms at rtol "
              f"{a['scipy_rtol']:g} ({a['scipy_peak_error_m']:.1e} m, "
              f"{a['scipy_impact_time_error_s']:.1e} s)")
    print()
    _print_continuation()
    print()
    _print_rotor_rub(repeats=repeats, quick=args.quick)
    print()
    _print_large_models(quick=args.quick, reduction=args.large)
    points = args.sweep_points if args.sweep_points is not None else (40 if args.quick else 400)
    if points > 0:
        from vibroimpact.benchmarks.sdof import sweep_benchmark
        from vibroimpact.benchmarks.sweep import format_rows

        print()
        rows = sweep_benchmark(points=points, repeats=1 if args.quick else 2)
        print("\n".join(format_rows(rows)))
    return 0


def _print_continuation() -> None:
    """Issue 21's speed target: a 200-point branch of the rigid impact oscillator with its
    multipliers in under 1 s, beside the brute-force sweep over the same range."""
    from vibroimpact.benchmarks.continuation import continuation_benchmark, reduced_orbit_benchmark

    c = continuation_benchmark()
    specials = ", ".join(f"{kind} at w = {w:.4f}" for kind, w in c["special_points"])
    print(f"Continuation (rigid impact oscillator, w = {c['w_range'][0]:.2f} to "
          f"{c['w_range'][1]:.4f}): {c['branch_points']} points with multipliers in "
          f"{c['branch_s']:.2f} s, CPU {c['branch_cpu_s']:.2f} s ({c['ms_per_point']:.1f} "
          f"ms/point, CPU {c['cpu_ms_per_point']:.1f}; target <= "
          f"{c['target_ms_per_point']:.0f}), {c['stable_points']} stable + "
          f"{c['unstable_points']} unstable{'; ' + specials if specials else ''}")
    print(f"  brute-force sweep over the same range ({c['sweep_points']} frequencies x 110 "
          f"periods, event-driven, 1 thread): {c['sweep_s']:.2f} s, CPU {c['sweep_cpu_s']:.2f} s; "
          f"on the period-1 orbit at "
          f"{c['sweep_period_one_points']} of them (the stable part only)")
    r = reduced_orbit_benchmark()
    print(f"  a large structure's orbit, monodromy in a reduced basis (the hollow shaft on its "
          f"sliders, {r['dofs']} DOFs; {r['retained'] - r['modes']} slider coordinates + "
          f"{r['modes']} modes, the rest by their own maps; HHT at T/1000): basis "
          f"{r['basis_s']:.2f} s (CPU {r['basis_cpu_s']:.2f}), transient of 60 periods + orbit "
          f"{r['orbit_s']:.2f} s (CPU {r['orbit_cpu_s']:.2f}), {r['iterations']} Newton "
          f"iterations to {r['residual']:.1e} |z|; {r['impacts_per_period']} impacts a period, "
          f"largest |multiplier| {r['largest_multiplier']:.4f} (complement "
          f"{r['complement_max']:.1e})")

def _print_rotor_rub(repeats: int, quick: bool) -> None:
    """Issue 22's speed targets: the Jeffcott rotor rubbing on a seal, 100 revolutions by
    DOP853 at least 100× SciPy's event-located DOP853 at the same rtol, 1,000 revolutions in
    under 50 ms, a sweep over 400 spin speeds (``quick``: 40) of 300 revolutions each in
    under 20 s on 2 cores."""
    from vibroimpact.benchmarks.rotor_rub import rub_benchmark, rub_sweep_benchmark

    b = rub_benchmark(repeats=repeats)
    print(f"Rotor rub (Jeffcott in a radial gap with friction, "
          f"examples/models/jeffcott_seal_rub.toml, DOP853 rtol {b['rtol']:g}): "
          f"{b['revolutions']} revolutions ({b['contacts']} "
          f"contacts) CPU {b['ours_s'] * 1e3:.2f} ms, SciPy solve_ivp DOP853 with located "
          f"contact events CPU {b['scipy_s'] * 1e3:.0f} ms ({b['scipy_contacts']} contacts): "
          f"{b['speedup']:.0f}x (target >= {b['target_speedup']:.0f}x); final displacements "
          f"within {b['final_difference_m']:.1e} m")
    print(f"  1,000 revolutions (target < {b['target_1000_s'] * 1e3:.0f} ms), CPU, error = "
          f"final displacement / deepest penetration against DOP853 rtol "
          f"{b['reference_rtol']:g} ({b['reference_contacts_1000']} contacts, deepest "
          f"{b['reference_delta_max_m']:.3e} m; converged to "
          f"{b['reference_convergence_m']:.1e} / {b['reference_delta_max_convergence_m']:.1e} m"
          f"; clearance {b['clearance_m']:g} m):")
    for label, key, contacts in (
            (f"DOP853 rtol {b['rtol']:g}", "dop853", "contacts_1000"),
            (f"DOP853 rtol {b['loose_rtol']:g}", "dop853_loose", "dop853_loose_contacts_1000"),
            (f"DOP853 rtol {b['coarse_rtol']:g}", "dop853_coarse", "dop853_coarse_contacts_1000"),
            ("Newmark 200 steps/rev", "newmark", "newmark_contacts_1000")):
        print(f"    {label:22s} {b[key + '_1000_s'] * 1e3:6.1f} ms, error "
              f"{b[key + '_1000_error_m']:.1e} / {b[key + '_1000_delta_max_error_m']:.1e} m "
              f"({b[contacts]} contacts)")
    s = rub_sweep_benchmark(points=40 if quick else 400)
    print(f"  sweep over {s['points']} spin speeds ({s['speeds'][0]:g}-{s['speeds'][1]:g} "
          f"rad/s) x {s['revolutions']} revolutions, Newmark, {s['threads']} threads: "
          f"{s['seconds']:.1f} s, CPU {s['cpu_seconds']:.1f} s (target < {s['target_s']:.0f} s "
          "on 2 cores)")


def _print_large_models(quick: bool, reduction: bool) -> None:
    """Issue 6's speed targets: the hollow shaft (1 s at 1 µs in under 1 s) and a 2,004-DOF
    imported model with 6 gaps (cost per step within 3× of its linear-only run); issue 23's:
    a 49,980-DOF solid with a gap (a step within 2× of its factor's bare substitution), the
    1,140-DOF CalculiX cantilever (≥ 100× ccx's own step) and, with ``reduction``, the
    Craig–Bampton reduction of the solid against a stop over a contact patch (within 1e-3 at
    a small fraction of the cost)."""
    from vibroimpact.benchmarks.large_models import (
        calculix_benchmark,
        hollow_shaft_benchmark,
        imported_model_benchmark,
        solid_model_benchmark,
        solid_reduction_benchmark,
    )

    t_end = 0.05 if quick else 1.0
    h = hollow_shaft_benchmark(t_end=t_end)
    print(f"Hollow shaft ({h['n_dof']} DOFs, 3 sliders, Newmark), {t_end:g} s at dt = 1 us: "
          f"{h['gaps_wall_time_s']:.3f} s ({h['gaps_us_per_step']:.3f} us/step; linear only "
          f"{h['linear_us_per_step']:.3f} us/step); target: 1 s simulated in under 1 s"
          + (" (--quick: 0.05 s)" if quick else ""))
    m = imported_model_benchmark(steps=2000)
    print(f"Imported model ({m['n_dof']} DOFs, {m['gaps']} gaps): {m['gaps_ms_per_step']:.3f} "
          f"ms/step vs linear only {m['linear_ms_per_step']:.3f} ms/step = {m['ratio']:.2f}x "
          f"(target: within 3x); Craig-Bampton to {m['reduced_n_dof']} DOFs in "
          f"{m['reduction_s']:.2f} s")
    s = solid_model_benchmark(steps=10 if quick else 20)
    print(f"Solid block ({s['n_dof']} DOFs of hexahedra, 1 gap, in contact "
          f"{s['contact_steps']} of {s['steps']} steps, Newmark): "
          f"{s['ms_per_step']:.2f} ms/step vs the bare substitution with its own factor "
          f"({s['solver']}, {s['stored_values']:,} values) {s['floor_ms']:.2f} ms = "
          f"{s['ratio']:.2f}x (target: within 2x); setup {s['setup_s']:.1f} s")
    c = calculix_benchmark(steps=500 if quick else 2000, ccx_steps=10 if quick else 30)
    if c is None:
        print("CalculiX cantilever (1,140 DOFs of C3D20, 1 gap): CalculiX not installed "
              "(no ccx on PATH)")
    else:
        print(f"CalculiX cantilever ({c['n_dof']:,} DOFs of C3D20, 1 gap, in contact "
              f"{c['contact_steps']} of {c['steps']} steps, Newmark, {c['solver']}): "
              f"{c['ms_per_step']:.3f} ms/step vs ccx *DYNAMIC, DIRECT without contact "
              f"{c['ccx_ms_per_step']:.1f} ms/step ({c['ccx_steps']} steps, 1 thread) = "
              f"{c['speedup']:.0f}x (target: >= 100x)")
    for r in solid_reduction_benchmark(steps=2000, n_modes=(50,),
                                       select=("frequency", "interface-mass")
                                       ) if reduction else ():
        chosen = ("lowest modes" if r["select"] == "frequency" else
                  f"modes of the most interface mass of the lowest {r['candidates']}")
        print(f"Craig-Bampton of the solid block ({r['n_dof']:,} DOFs to {r['reduced_n_dof']}: "
              f"the {r['patch_nodes']} contact-patch DOFs + {r['n_modes']} {chosen}), "
              f"{r['steps']} steps of {r['dt'] * 1e6:g} us, in contact {r['contact_steps']}: "
              f"patch gap displacement error {r['displacement_error']:.1e} (over the steps in "
              f"contact {r['contact_displacement_error']:.1e}), contact force error "
              f"{r['force_error']:.1e} (target: within 1e-3); reduction "
              f"{r['reduction_s']:.1f} s + reduced run {r['reduced_run_s'] * 1e3:.1f} ms vs "
              f"full run {r['full_run_s']:.1f} s = {r['cost_fraction']:.2f} of the cost (the "
              f"reduction = {r['reduction_s'] / (r['full_ms_per_step'] * 1e-3):.0f} full "
              "steps; target: a small fraction)")
