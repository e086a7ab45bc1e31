"""``vibroimpact run MODEL.toml [-o OUT.nc|OUT.h5|OUT.csv] [--stream] [--json]``: run a model
file.

The model file (``docs/model-file.md``) and ``-o`` are checked before anything runs; every
mistake is reported as one line and the command exits with code 2. Results are written
atomically: a failed or interrupted run never leaves a partial file behind. ``Ctrl-C`` or
SIGTERM during the run stops it and writes the results up to then, marked incomplete; after
the run (while the result is converted and written) it lets the complete file be written
first (:func:`vibroimpact.io.results_file.hold_signals`). Either way the exit code is
128 + the signal's number.
"""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import warnings
from pathlib import Path
from typing import Any

from vibroimpact.cli.verbosity import add_verbosity_options, configure_logging, log_run
from vibroimpact.errors import Interrupted, ModelError, PreRunWarning, SolverError
from vibroimpact.io import results_file
from vibroimpact.io.model_file import ModelFile, ModelFileError, load_model
from vibroimpact.simulate import pre_run_warnings

__all__ = ["OUTPUT_SUFFIXES", "add_parser", "main"]

#: The result formats ``-o`` writes, by file suffix.
OUTPUT_SUFFIXES = results_file.SUFFIXES

log = logging.getLogger("vibroimpact.run")

#: ``--stream`` is implied when the time histories would take more than this, bytes.
STREAM_ABOVE_BYTES = 2**30
#: Steps per block handed to the writer when streaming (``--window``).
STREAM_WINDOW_STEPS = 200_000

_DESCRIPTION = """\
Run a model file: a structure with clearances, its loads and the solver settings
(the format is described in docs/model-file.md). Prints the peak displacement of each
recorded DOF, the number of impacts, solver statistics and the energy balance error."""

_EPILOG = """\
examples:
  vibroimpact run examples/models/sdof_paper_ln.toml
  vibroimpact run model.toml --json
  vibroimpact run model.toml -o results.nc    # NetCDF-4 (HDF5): xarray, MATLAB ncread
  vibroimpact run model.toml -o results.csv   # also results_impacts.csv, results_energy.csv,
                                              # results_meta.json
  vibroimpact run long.toml -o long.nc --stream    # rows written to disk as computed
  vibroimpact run model.toml --verbose            # log step cuts and contacts as they happen

exit codes: 0 done, 2 mistakes in the model file or the arguments (one line each),
3 the solver failed, 130 interrupted by Ctrl-C, 143 by SIGTERM. After a failure or an
interrupt, -o OUT holds the results up to then, marked incomplete (attribute complete = 0;
"complete": 0 in OUT_meta.json). A run longer than a second shows a progress bar on stderr
(when stderr is a terminal; not with --quiet). -o OUT.nc/.h5 streams automatically when the
time histories would take more than 1 GiB."""


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``run`` subcommand to ``subparsers`` (from ``add_subparsers``)."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "run",
        help="run a model file (TOML)",
        description=_DESCRIPTION,
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("model", metavar="MODEL.toml", help="the model file to run")
    parser.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="write the result to OUT, atomically: .nc/.h5 (NetCDF-4: time histories, "
        "impact table, energy account, model and solver settings) or .csv (time histories "
        "with units in the column names; OUT_impacts.csv, OUT_energy.csv and OUT_meta.json "
        "next to it)",
    )
    parser.add_argument(
        "--stream",
        action="store_true",
        help="write the time histories to OUT (.nc/.h5) while the run goes on instead of "
        "holding them in memory (automatic above 1 GiB of time histories); the file is the "
        "same",
    )
    parser.add_argument(
        "--window",
        type=int,
        default=None,
        metavar="STEPS",
        help="with --stream (implied): hand the rows to the writer every STEPS steps "
        f"(default {STREAM_WINDOW_STEPS})",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the summary as one JSON object (keys: max_abs_displacement, impacts, "
        "steps, newton_iterations, wall_time_s, energy_balance_error, ...)",
    )
    add_verbosity_options(parser)
    parser.set_defaults(handler=main)
    return parser


def _output_errors(output: str | None) -> tuple[Path | None, list[str]]:
    if output is None:
        return None, []
    path = Path(output)
    if path.suffix.lower() not in OUTPUT_SUFFIXES:
        return None, [
            f"-o: {output!r} is not valid; expected a file name ending in "
            f"{' or '.join(OUTPUT_SUFFIXES)}"
        ]
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        return None, [f"-o: {output!r} is not valid; expected a file in an existing folder"]
    return path, []


def _print_summary(mf: ModelFile, summary: dict[str, Any]) -> None:
    model = mf.model
    n_gaps = len(model.gaps)
    print(
        f"{mf.path.name}: {model.n_dof} DOF{'s' * (model.n_dof != 1)}, "
        f"{n_gaps} gap{'s' * (n_gaps != 1)}, {len(model.loads)} load(s), "
        f"method {mf.method.name}, dt = {summary['dt']:g} s, t_end = {summary['t_end']:g} s"
    )
    for dof, unit, peak in zip(summary["dofs"], summary["dof_units"],
                               summary["max_abs_displacement"], strict=True):
        print(f"  peak |x{dof}|           {peak:.6e} {unit}")
    print(f"  impacts              {len(summary['impacts'])}")
    print(f"  steps                {summary['steps']}")
    print(f"  Newton iterations    {summary['newton_iterations']}")
    print(f"  wall time            {summary['wall_time_s']:.4f} s")
    print(f"  energy balance error {summary['energy_balance_error']:.3e} (relative)")


def _stopped(e: SolverError, out: Path | None, args: argparse.Namespace) -> int:
    """Report a run that stopped early (solver failure or interrupt) on one line, write its
    partial results to ``out`` (marked incomplete) and return the exit code."""
    interrupted = isinstance(e, Interrupted)
    what = "interrupted" if interrupted else "solver failed"
    print(f"vibroimpact: {what}: {e}", file=sys.stderr)
    partial = e.partial
    if e.written:
        print(f"vibroimpact: wrote the results up to the failure (marked incomplete) to "
              f"{', '.join(str(p) for p in e.written)}", file=sys.stderr)
    if partial is not None:
        if out is not None and not e.written:
            try:
                written = results_file.save(partial, out)
            except OSError as err:
                print(f"vibroimpact: error: -o: cannot write {str(err.filename or out)!r}: "
                      f"{err.strerror}", file=sys.stderr)
            else:
                state = "complete" if partial.complete else "marked incomplete"
                print(f"vibroimpact: wrote the results up to t = {partial.time[-1]:.6g} s "
                      f"({state}) to {', '.join(str(p) for p in written)}", file=sys.stderr)
        if args.json:
            json.dump(partial.summary(), sys.stdout)
            sys.stdout.write("\n")
    if interrupted:
        return 128 + int(getattr(e, "signum", signal.SIGINT))
    return 3


def _history_bytes(mf: ModelFile) -> float:
    """Size of the time histories a fixed-step run of ``mf`` records, bytes (adaptive: 0,
    unknown in advance)."""
    if mf.method.adaptive is not None:
        return 0.0
    rows = mf.t_end / mf.dt / mf.every + 2
    n_dofs = mf.model.n_dof if mf.dofs is None else len(mf.dofs)
    return 8.0 * rows * (1 + 3 * n_dofs + 2 * len(mf.model.gaps) + 6)


def _run(mf: ModelFile, out: Path | None, stream: bool, args: argparse.Namespace
         ) -> tuple[dict[str, Any], list[Path]]:
    """Run ``mf`` (streamed to ``out`` or in memory, then written to ``out``): the summary
    and the files written. Raises :class:`SolverError` if the run stopped early."""
    for warning in pre_run_warnings(mf.model, mf.method, mf.dt):
        print(f"vibroimpact: warning: {warning}", file=sys.stderr)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PreRunWarning)  # printed above
        if stream and out is not None:
            summary = results_file.simulate_to_file(
                mf.model, out, mf.t_end, mf.dt, mf.method, every=mf.every, dofs=mf.run_dofs,
                window_steps=args.window or STREAM_WINDOW_STEPS, progress_bar=not args.quiet,
                recovery=mf.recovery(), dof_map=mf.dof_map,
            )
            return summary, [out]
        result = mf.simulate(progress=not args.quiet)
    summary = result.summary()
    return summary, (results_file.save(result, out) if out is not None else [])


def main(args: argparse.Namespace) -> int:
    """Run ``args.model``; print a summary (``--json``: one JSON object); write ``-o``."""
    out, errors = _output_errors(args.output)
    try:
        mf = load_model(args.model)
    except ModelFileError as e:
        raise ModelFileError(e.errors + errors) from None
    netcdf = out is not None and out.suffix.lower() in results_file.NETCDF_SUFFIXES
    for flag, given in (("--stream", args.stream), ("--window", args.window is not None)):
        if given and not netcdf:
            value = "" if flag == "--stream" else f" {args.window!r}"
            errors.append(f"{flag}:{value} is given without -o OUT.nc or OUT.h5; expected -o "
                          "with a NetCDF file to stream to")
    if args.window is not None and netcdf and args.window < 2:
        errors.append(f"--window: {args.window!r} is not valid; expected an integer >= 2")
    if errors:
        raise ModelFileError(errors)
    configure_logging(args)
    stream = netcdf and (args.stream or args.window is not None
                         or _history_bytes(mf) > STREAM_ABOVE_BYTES)
    # a signal after the run (while the result is converted and written) is held until the
    # file is complete; one during the run stops it (vibroimpact.simulate catches it)
    with results_file.hold_signals() as held:
        try:
            summary, written = _run(mf, out, stream, args)
        except SolverError as e:
            return _stopped(e, out, args)
        except OSError as e:
            raise ModelError(f"-o: cannot write {str(e.filename or out)!r}: "
                             f"{e.strerror}") from None
        log_run(log, summary)
        if args.json:
            json.dump(summary, sys.stdout)
            sys.stdout.write("\n")
        elif not args.quiet:
            _print_summary(mf, summary)
            if written:
                print(f"  wrote {', '.join(str(p) for p in written)}")
    if held.signum is not None:
        name = signal.Signals(held.signum).name
        done = f"; the complete results were written to {out}" if written else ""
        print(f"vibroimpact: interrupted: {name} received after the run finished{done}",
              file=sys.stderr)
        return 128 + held.signum
    return 0
