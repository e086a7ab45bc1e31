"""``vibroimpact orbit MODEL.toml [--period N] [--transient N] [--modes N] [-o ORBIT.nc]
[--json]``: the periodic orbit of a model file with a harmonic load, by shooting, and its
Floquet multipliers (docs/periodic-orbits.md)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from vibroimpact.errors import ModelError
from vibroimpact.io import results_file
from vibroimpact.io.model_file import load_model
from vibroimpact.orbits import PeriodicOrbit, file_step, periodic_orbit

__all__ = ["add_parser", "main", "netcdf_output"]

_DESCRIPTION = """\
Find the periodic orbit of a model file: simulate --transient forcing periods from its initial
state, then solve P^N(z) = z by Newton on the stroboscopic map of N = --period forcing periods,
with the exact Jacobian of the map (state-transition matrix and saltation matrices). Prints the
orbit's state on the section (t = 0 of a forcing period), its peaks and impacts, and its
Floquet multipliers (stable: all inside the unit circle). The forcing period is the common
period of the harmonic loads. The file's method must carry the state-transition matrix:
dop853 (compliant laws; its tolerances are used; its first step is the forcing period / 1000),
event-driven (rigid stops; 200 steps a forcing period: its flights are exact and the
displacements' extremes are located inside them) or the Newmark family at fixed steps (the
file's dt, shortened to a whole number of steps a forcing period). Above 200 DOFs (or with
--modes) the monodromy is formed in a reduced basis (the Newmark family)."""

_EPILOG = """\
examples:
  vibroimpact orbit oscillator.toml --json
  vibroimpact orbit oscillator.toml --period 2 --transient 200 -o orbit.nc

exit codes: 0 done, 2 mistakes in the model file or the arguments (one line each),
3 Newton did not converge (the residual is named)."""


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``orbit`` subcommand to ``subparsers``."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "orbit", help="periodic orbit and Floquet multipliers (shooting)",
        description=_DESCRIPTION, epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model", metavar="MODEL.toml", help="the model file")
    parser.add_argument("--period", type=int, default=1, metavar="N",
                        help="forcing periods per orbit (default 1)")
    parser.add_argument("--transient", type=int, default=50, metavar="N",
                        help="forcing periods simulated before Newton starts (default 50; 0: "
                        "the file's initial state is the guess)")
    parser.add_argument("--modes", type=int, default=None, metavar="N",
                        help="form the monodromy in a reduced basis: the gap coordinates plus "
                        "N fixed-interface modes (the Newmark family; always so above 200 "
                        "DOFs, by default every mode up to 10x the forcing frequency, at "
                        "least 20)")
    parser.add_argument("-o", "--output", metavar="ORBIT.nc",
                        help="write the orbit's time histories over its period, its "
                        "multipliers and monodromy matrix (NetCDF-4: .nc or .h5)")
    parser.add_argument("--json", action="store_true",
                        help="print the summary as one JSON object (keys: multipliers, "
                        "stable, period, residual, initial_state, displacement_max, "
                        "displacement_min, impacts_per_period, force_max, penetration_max)")
    parser.set_defaults(handler=main)
    return parser


def netcdf_output(output: str | None) -> Path | None:
    """The checked path of ``-o`` (NetCDF-4, in an existing folder), or None."""
    if output is None:
        return None
    path = Path(output)
    if path.suffix.lower() not in results_file.NETCDF_SUFFIXES:
        raise ModelError(f"-o: {output!r} is not valid; expected a file name ending in "
                         f"{' or '.join(results_file.NETCDF_SUFFIXES)}")
    if not (path.parent if str(path.parent) else Path(".")).is_dir():
        raise ModelError(f"-o: {output!r} is not valid; expected a file in an existing folder")
    return path


def write_result(dataset: Any, summary: dict[str, Any], out: Path | None,
                 as_json: bool) -> bool:
    """Save ``dataset`` to the checked ``-o`` path (if any) and print ``summary`` as one JSON
    line when ``--json``; False if the caller still has to print its text summary."""
    if out is not None:
        try:
            results_file.save(dataset, out)
        except OSError as err:
            raise ModelError(f"-o: cannot write {str(err.filename or out)!r}: "
                             f"{err.strerror}") from None
    if as_json:
        json.dump(summary, sys.stdout)
        sys.stdout.write("\n")
    return as_json


def _print(orbit: PeriodicOrbit, name: str) -> None:
    s = orbit.summary()
    print(f"{name}: periodic orbit of {orbit.shooting.periods} forcing period(s), "
          f"T = {s['period']:.9g} s, residual {s['residual']:.3e}, "
          f"{orbit.iterations} Newton iteration(s)")
    for d, (x, v) in enumerate(zip(orbit.displacement, orbit.velocity, strict=True)):
        print(f"  x{d}(0) = {x:.9e}, v{d}(0) = {v:.9e}, "
              f"x{d} in [{s['displacement_min'][d]:.6e}, {s['displacement_max'][d]:.6e}]")
    print(f"  impacts per period   {s['impacts_per_period']}")
    for m in orbit.multipliers:
        print(f"  multiplier           {m.real:+.9f} {m.imag:+.9f}i  |{abs(m):.9f}|")
    if orbit.basis:
        print(f"  basis                {orbit.basis}")
        print(f"  complement |mult.|  <= {s['complement_multiplier_max']:.3e}")
    print(f"  stable               {'yes' if orbit.stable else 'no'}")


def main(args: argparse.Namespace) -> int:
    """Run ``vibroimpact orbit``."""
    out = netcdf_output(args.output)
    mf = load_model(args.model)
    orbit = periodic_orbit(mf.model, period=args.period, transient=args.transient,
                           method=mf.method, dt=file_step(mf.method, mf.dt, mf.model),
                           modes=args.modes)
    if not write_result(orbit.to_dataset(), orbit.summary(), out, args.json):
        _print(orbit, Path(args.model).name)
    return 0
