"""``vibroimpact sweep MODEL.toml --param PATH=SPEC [--param ...] -o SWEEP.nc``: a parameter
sweep of a model file, in this process on all cores or on Dask (``--dask``, ``--scheduler``).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from vibroimpact.errors import ModelError, SolverError

__all__ = ["add_parser", "main"]

#: Failed points whose message is printed (the Dataset's ``failed`` variable has them all).
_FAILURES_SHOWN = 5

_DESCRIPTION = """\
Run a model file for every point of a parameter grid (one or more --param, their Cartesian
product) and keep, per point, the Poincare samples of displacement and velocity at the
forcing phase, the peak and RMS displacement, and the impact counts, speeds and phases after
the transient. --transient and --periods count periods of the first harmonic load. The
result is an xarray Dataset written to NetCDF-4 (dims: one per parameter, sample, dof, gap);
draw it with `vibroimpact plot SWEEP.nc --kind bifurcation` or `--kind response`.

Without --dask or --scheduler the sweep runs in this process on all cores. Finished chunks
are kept in OUT.parts/ so that a killed sweep, started again with the same arguments,
continues where it stopped; the parts are removed once OUT is written."""

_EPILOG = """\
parameter paths (model-file names; gaps[0].clearance and gaps.0.clearance are the same):
  loads.L.frequency, loads.L.amplitude, loads.L.phase, gaps.G.clearance,
  gaps.G.law.restitution, gaps.G.law.stiffness (any number of the law),
  structure.mass, structure.stiffness, structure.damping (one DOF; else structure.K.I.J),
  initial.displacement, initial.velocity (one DOF; else initial.velocity.I)
values: A:B:N (N values from A to B), A:B:N:log (log spacing), V1,V2,... (a list)

examples:
  vibroimpact sweep examples/models/impact_oscillator.toml \\
      --param loads.0.frequency=5:50:400 --transient 200 --periods 100 -o sweep.nc
  vibroimpact plot sweep.nc --kind bifurcation -o bifurcation.png
  vibroimpact sweep model.toml --param loads.0.frequency=5:50:200 --continuation both \\
      -o response.nc && vibroimpact plot response.nc --kind response -o response.png
  vibroimpact sweep model.toml --param gaps.0.clearance=1e-4:1e-2:50:log \\
      --param gaps.0.law.restitution=0.5,0.7,0.9 -o grid.nc
  vibroimpact sweep model.toml --param loads.0.frequency=5:50:4000 --dask --workers 8 -o s.nc
  vibroimpact sweep model.toml --param loads.0.frequency=5:50:4000 \\
      --scheduler tcp://head:8786 -o s.nc

choosing a method (--method NAME overrides the file's [solver] method; docs/sweeps.md):
  a few DOFs with compliant contacts: dop853 (on the example oscillator, 40 frequencies x
  100 periods: 95 thousand steps in 0.43 s against 1.2 million in 0.61 s for adaptive
  Newmark and 2.1 million in 0.45 s for Newmark at dt = 1e-4, peaks within 1.5e-7 and
  7.8e-7 m of it); stiff FE models (beams, many DOFs): newmark (adaptive or fixed dt) or
  generalized-alpha, since DOP853's explicit step is bounded by the stiffest mode; rigid
  stops: event-driven or moreau-jean.

exit codes: 0 done (some points may have failed: the summary counts them), 2 mistakes in
the model file or the arguments (one line each), 3 every point failed (the Dataset is still
written), 130 / 143 stopped by Ctrl-C / SIGTERM (the finished chunks are kept in OUT.parts/;
the same command resumes)."""


def _method_names() -> list[str]:
    from vibroimpact.integrators import METHODS

    return list(METHODS)


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``sweep`` subcommand to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "sweep",
        help="parameter sweep of a model file: bifurcation diagrams, response curves",
        description=_DESCRIPTION,
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", metavar="MODEL.toml", help="the model file")
    p.add_argument("--param", action="append", required=True, metavar="PATH=SPEC",
                   help="a swept parameter and its values (repeat for a grid)")
    p.add_argument("--transient", type=int, default=100, metavar="N",
                   help="forcing periods run before sampling (default 100)")
    p.add_argument("--periods", type=int, default=100, metavar="N",
                   help="forcing periods sampled (default 100)")
    p.add_argument("-o", "--output", required=True, metavar="SWEEP.nc",
                   help="the Dataset, written atomically (.nc or .h5)")
    p.add_argument("--continuation", choices=("none", "up", "down", "both"), default="none",
                   help="run the points along the first --param one after the other, each "
                   "from the previous final state: up (in the order of the values), down, "
                   "or both (response curves with hysteresis); default none (every point "
                   "from the model's initial state)")
    p.add_argument("--dof", type=int, action="append", dest="dofs", metavar="N",
                   help="DOF to sample (repeat; default: the model file's output DOFs, else "
                   "all up to 8 DOFs, else the gaps' DOFs)")
    p.add_argument("--period-load", type=int, default=None, metavar="L",
                   help="the harmonic (or unbalance) load whose period --transient, --periods "
                   "and the samples count (default the first such load)")
    p.add_argument("--samples-per-period", type=int, default=1, metavar="N",
                   help="samples of each sampled period (default 1: the Poincare section; "
                   "more: a time history at T/N for spectra, e.g. --kind waterfall)")
    p.add_argument("--max-impacts", type=int, default=None, metavar="K",
                   help="impact speeds and phases kept per gap and point (default --periods, "
                   "at most 1000)")
    p.add_argument("--chunk-size", type=int, default=None, metavar="N",
                   help="points per chunk (one core call or Dask task; default about 20 "
                   "chunks)")
    p.add_argument("--threads", type=int, default=None, metavar="N",
                   help="core threads per chunk (default all cores; with --dask, cores / "
                   "workers)")
    p.add_argument("--dask", action="store_true",
                   help="run the chunks on a Dask LocalCluster started for the sweep "
                   "(needs pip install 'vibroimpact[distributed]')")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="--dask: worker processes (default one per core)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the chunks on an existing Dask cluster, e.g. tcp://host:8786")
    p.add_argument("--restart", action="store_true",
                   help="ignore the parts of an interrupted run and start again")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    p.add_argument("--method", default=None, metavar="NAME",
                   help="run every point with this method at its default settings instead of "
                   "the model file's [solver] method (dt stays the file's); one of "
                   + ", ".join(_method_names()) + ". See 'choosing a method' below")
    p.add_argument("--json", action="store_true", help="print a summary as JSON")
    p.set_defaults(handler=main)
    return p


def main(args: argparse.Namespace) -> int:
    """Check everything, run the sweep, write ``-o`` and print a summary."""
    import shutil
    from pathlib import Path

    from vibroimpact.io.model_file import load_model
    from vibroimpact.sweeps import Sweep, parse_param, run_sweep
    from vibroimpact.sweeps.runner import _check_output

    out = _check_output(args.output)
    if args.scheduler and args.dask:
        raise ModelError("--scheduler: given with --dask; expected one of them (--dask starts "
                         "a local cluster, --scheduler uses an existing one)")
    if args.workers is not None and not args.dask:
        raise ModelError("--workers: given without --dask; expected --dask with it")
    if args.workers is not None and args.workers < 1:
        raise ModelError(f"--workers: {args.workers} is not valid; expected an integer >= 1")
    params = [parse_param(text) for text in args.param]
    mf = load_model(args.model)
    options: dict[str, Any] = {"transient": args.transient, "periods": args.periods,
                               "continuation": args.continuation,
                               "max_impacts": args.max_impacts, "chunk_size": args.chunk_size,
                               "period_load": args.period_load,
                               "samples_per_period": args.samples_per_period}
    if args.dofs:
        options["dofs"] = args.dofs
    if args.method is not None:
        options["method"] = _method(args.method, mf.model)
    sweep = Sweep.from_model_file(mf, params, **options)
    if args.restart:
        shutil.rmtree(Path(str(out) + ".parts"), ignore_errors=True)
    progress = False if args.quiet else None
    if args.dask or args.scheduler:
        from vibroimpact.sweeps.distributed import dask_client

        with dask_client(workers=args.workers, scheduler=args.scheduler) as (client, threads):
            ds = run_sweep(sweep, output=out, client=client,
                           threads=args.threads or threads, progress=progress)
    else:
        ds = run_sweep(sweep, output=out, threads=args.threads, progress=progress)
    summary = {
        "output": str(out),
        "points": int(sweep.n_points),
        "grid": {p.path: len(p) for p in params},
        "failed_points": int(ds.attrs["failed_points"]),
        "impacting_points": int((ds["impact_count"].sum("gap") > 0).sum()),
        "steps": int(ds["steps"].sum()),
        "wall_time_s": float(ds.attrs["wall_time_s"]),
        "chunks_computed": int(ds.attrs["chunks_computed"]),
        "chunks_reused": int(ds.attrs["chunks_reused"]),
        "where": ("dask " + (args.scheduler or "LocalCluster")) if (args.dask or args.scheduler)
        else "in-process",
    }
    failures = json.loads(ds.attrs["errors"])
    if args.json:
        print(json.dumps(summary))
    if summary["failed_points"] == summary["points"]:
        first = failures[0]
        raise SolverError(f"every one of the {summary['points']} points failed (first: "
                          f"{first['point']}: {first['message']}); the Dataset (every point "
                          f"marked failed) was written to {out}")
    if not args.json:
        for e in failures[:_FAILURES_SHOWN]:
            print(f"  failed: {e['point']}: {e['message']}", file=sys.stderr)
        failed = ""
        if summary["failed_points"]:
            shown = min(_FAILURES_SHOWN, summary["failed_points"])
            listed = f"the first {shown}" if shown < summary["failed_points"] else "listed"
            failed = (f" ({listed} above; all are marked in the Dataset's variable failed, "
                      "docs/sweeps.md: Failed points)")
        print(f"{summary['points']} points ({' x '.join(map(str, summary['grid'].values()))}) "
              f"in {summary['wall_time_s']:.2f} s {summary['where']}: "
              f"{summary['impacting_points']} impacting, {summary['failed_points']} of "
              f"{summary['points']} failed{failed}; written to {out}")
    return 0


def _method(name: str, model: Any) -> Any:
    """The integrator ``--method NAME`` asks for, at its default settings, refused (before
    any point runs) when it cannot take the model's gaps: the impulsive methods take rigid
    gaps only, the others force laws only."""
    from vibroimpact.integrators import METHODS, method_from_options

    if name not in METHODS:
        raise ModelError(f"--method: {name!r} is not valid; expected one of "
                         f"{', '.join(METHODS)}")
    method = method_from_options(name)
    for g, gap in enumerate(model.gaps):
        if (gap.law.kind == "rigid") != method.impulsive:
            takers = [m for m, c in METHODS.items() if c.impulsive == (gap.law.kind == "rigid")]
            raise ModelError(f"--method: {name!r} cannot take gaps[{g}].law.kind = "
                             f"{gap.law.kind!r}; expected one of {', '.join(takers)}")
    return method
