"""``vibroimpact continue MODEL.toml --param PATH=START:END [--period N] [--max-points N]
[--switch] [--modes N] [-o BRANCH.nc] [--json]``: pseudo-arclength continuation of a model file's
periodic orbit in one parameter, with stability and special points
(docs/periodic-orbits.md, Continuation)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from vibroimpact.continuation import Branch, continue_orbit
from vibroimpact.errors import ModelError
from vibroimpact.io.model_file import load_model
from vibroimpact.orbits import file_step
from vibroimpact.sweeps.grid import canonical_path

__all__ = ["add_parser", "main", "parse_range"]

_DESCRIPTION = """\
Follow the periodic orbit of a model file in one numeric parameter (the paths of `sweep
--param`) by pseudo-arclength continuation, stable and unstable parts alike: it starts from
the orbit found at START as `vibroimpact orbit` finds it (--transient forcing periods, then
Newton on the stroboscopic map of --period forcing periods) and stops when the parameter
reaches END (or START again after a fold) or after --max-points points. Each point has its
Floquet multipliers; folds, period-doublings, Neimark-Sacker and branch points (test
functions on the multipliers) and grazings (a wall touched or left) are located between
points. --switch: at the first period-doubling, go on along the period-2 branch born there.
The file's method must carry the state-transition matrix: dop853 (compliant laws),
event-driven (rigid stops) or the Newmark family at fixed steps (the file's dt, shortened to
a whole number of steps a forcing period). Above 200 DOFs (or with
--modes) the monodromy is formed in a reduced basis (the Newmark family): the gap coordinates
plus N fixed-interface modes, each other mode by its own closed-form map."""

_EPILOG = """\
examples:
  vibroimpact continue oscillator.toml --param loads.0.frequency=0.17:0.25 --json
  vibroimpact continue oscillator.toml --param gaps.0.clearance=0.5:0.1 --switch -o branch.nc

exit codes: 0 done, 2 mistakes in the model file or the arguments (one line each),
3 no orbit at START or a step that failed at the smallest step."""

_RANGE_HELP = "PATH=START:END, e.g. loads.0.frequency=0.17:0.25"


def parse_range(text: str) -> tuple[str, float, float]:
    """``PATH=START:END`` → ``(path, start, end)``."""
    path, sep, spec = text.partition("=")
    parts = spec.split(":")
    bad = ModelError(f"--param: {text!r} is not valid; expected {_RANGE_HELP}")
    if not sep or not canonical_path(path) or len(parts) != 2:
        raise bad
    try:
        start, end = float(parts[0]), float(parts[1])
    except ValueError:
        raise bad from None
    if not (math.isfinite(start) and math.isfinite(end)) or start == end:
        raise bad
    return canonical_path(path), start, end


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``continue`` subcommand to ``subparsers``."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "continue", help="continuation of a periodic orbit in a parameter: branches, "
        "stability, folds, period-doublings, grazings",
        description=_DESCRIPTION, epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model", metavar="MODEL.toml", help="the model file")
    parser.add_argument("--param", required=True, metavar="PATH=START:END",
                        help="the parameter and the range to follow it over")
    parser.add_argument("--period", type=int, default=1, metavar="N",
                        help="forcing periods per orbit (default 1)")
    parser.add_argument("--transient", type=int, default=50, metavar="N",
                        help="forcing periods simulated at START before Newton (default 50)")
    parser.add_argument("--max-points", type=int, default=200, metavar="N",
                        help="points at most (default 200)")
    parser.add_argument("--switch", action="store_true",
                        help="at the first period-doubling, follow its period-2 branch")
    parser.add_argument("--modes", type=int, default=None, metavar="N",
                        help="form the monodromy in a reduced basis: the gap coordinates plus "
                        "N fixed-interface modes (the Newmark family; always so above 200 "
                        "DOFs, by default every mode up to 10x the forcing frequency, at "
                        "least 20)")
    parser.add_argument("-o", "--output", metavar="BRANCH.nc",
                        help="write the branch along its arclength (NetCDF-4: .nc or .h5)")
    parser.add_argument("--json", action="store_true",
                        help="print the branch as one JSON object (keys: parameter, points, "
                        "special_points)")
    parser.set_defaults(handler=main)
    return parser


def _print(branch: Branch, name: str) -> None:
    pts = branch.points
    print(f"{name}: {len(pts)} points along {branch.parameter} from {pts[0].value:.9g} to "
          f"{pts[-1].value:.9g}, {sum(p.stable for p in pts)} stable")
    for s in branch.special_points:
        worst = max(s.point.multipliers, key=abs)
        print(f"  {s.type:<16} {branch.parameter} = {s.point.value:.9g}  (|multiplier| max "
              f"{abs(worst):.6f})")
    if branch.stopped:
        print(f"  {branch.stopped}")
    if branch.basis:
        print(f"  basis: {branch.basis}")


def main(args: argparse.Namespace) -> int:
    """Run ``vibroimpact continue``."""
    from vibroimpact.cli.orbit import netcdf_output, write_result

    out = netcdf_output(args.output)
    path, start, end = parse_range(args.param)
    mf = load_model(args.model)
    branch = continue_orbit(mf.model, path, start, end, period=args.period,
                            transient=args.transient, method=mf.method,
                            dt=file_step(mf.method, mf.dt, mf.model),
                            max_points=args.max_points, switch=args.switch,
                            modes=args.modes)
    if not write_result(branch.to_dataset(), branch.summary(), out, args.json):
        _print(branch, Path(args.model).name)
    return 0
