"""``vibroimpact modal MODEL.toml [--modes N] [--speed A:B:N] [--json] [--plot FILE]``: natural
frequencies and mode shapes of a model file's structure (:mod:`vibroimpact.fe.modal`), or a
rotor's Campbell diagram over spin speeds (:func:`vibroimpact.rotor.campbell`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from vibroimpact.errors import ModelError

__all__ = ["add_parser", "main"]

_DESCRIPTION = """\
Natural frequencies and mode shapes of the structure of a model file (K phi = w^2 M phi;
dense LAPACK for small models, ARPACK shift-invert for large ones). Rigid-body modes
(free-free structures) are counted and reported at 0 Hz; the table lists them, then the
first N elastic modes. The [solver] table is not needed. With --speed, a rotor's Campbell
diagram instead: the first N damped natural frequencies of M x'' + (C + W G) x' + K x = 0 at
each spin speed W, each mode's whirl forward, backward, mixed or none (docs/rotors.md)."""

_EPILOG = """\
examples:
  vibroimpact modal examples/models/hollow_shaft.toml --modes 3
  vibroimpact modal model.toml --json        # {"frequencies_hz": [...], "rigid_body_modes": 2}
  vibroimpact modal model.toml --plot modes.png
  vibroimpact modal rotor.toml --speed 0:1000:21 --modes 4 --plot campbell.png"""


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``modal`` subcommand to ``subparsers``."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "modal",
        help="natural frequencies and mode shapes of a model file's structure",
        description=_DESCRIPTION,
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("model", metavar="MODEL.toml", help="the model file")
    parser.add_argument(
        "--modes", type=int, default=10, metavar="N", help="elastic modes to compute (default 10)"
    )
    parser.add_argument(
        "--speed",
        metavar="A:B:N",
        help="the Campbell diagram at N spin speeds from A to B rad/s (a rotor: "
        "structure.gyroscopic or a beam with dofs_per_node = 4)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object: frequencies_hz (the elastic modes, first to last), "
        "rigid_body_modes (count) and modes (one row per mode); with --speed: speeds_rad_s, "
        "frequencies_rad_s, frequencies_hz, damping_ratios (rows: speeds) and whirl",
    )
    parser.add_argument(
        "--plot",
        metavar="FILE",
        help="save a plot of the first elastic mode shapes, or with --speed the Campbell "
        "diagram (.png, .svg or .pdf)",
    )
    parser.set_defaults(handler=main)
    return parser


def _load(path: str) -> Any:
    """The checked model file; a file without ``[solver]`` is accepted (modal needs none)."""
    from vibroimpact.io import model_file

    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return model_file.load_model(p)  # reports the problem in the loader's words
    doc = model_file._parse(text, p.name)
    if "solver" not in doc:
        doc["solver"] = {"dt": 1.0, "t_end": 1.0}  # not used
    return model_file._check_document(doc, p)


def main(args: argparse.Namespace) -> int:
    """Compute and print the modes of ``args.model``."""
    from vibroimpact.fe.modal import modes, plot_mode_shapes

    if args.modes < 1:
        raise ModelError(f"--modes: {args.modes!r} is not valid; expected an integer >= 1")
    if args.plot is not None and Path(args.plot).suffix.lower() not in (".png", ".svg", ".pdf"):
        raise ModelError(f"--plot: {args.plot!r} is not valid; expected a .png, .svg or .pdf file")
    mf = _load(args.model)
    if args.speed is not None:
        return _campbell(args, mf)
    beam = getattr(mf, "beam", None)
    result = modes(beam if beam is not None else mf.model.structure, args.modes)
    records = result.to_records()
    if args.plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        fig = plot_mode_shapes(result, beam, n_modes=min(args.modes, 6))
        fig.savefig(args.plot, dpi=120, bbox_inches="tight")
    if args.json:
        out = {
            "frequencies_hz": [float(f) for f in result.elastic_frequencies_hz],
            "rigid_body_modes": result.rigid_body_modes,
            "n_dof": int(result.shapes.shape[0]),
            "modes": records,
        }
        json.dump(out, sys.stdout)
        sys.stdout.write("\n")
        return 0
    n = result.shapes.shape[0]
    print(f"{Path(args.model).name}: {n} DOFs, {result.rigid_body_modes} rigid-body mode(s)")
    print(f"  {'mode':>4}  {'kind':<7}  {'frequency [Hz]':>14}  {'omega [rad/s]':>14}")
    for r in records:
        print(
            f"  {r['mode']:>4}  {r['kind']:<7}  {r['frequency_hz']:>14.6g}  "
            f"{r['angular_frequency_rad_s']:>14.6g}"
        )
    if args.plot is not None:
        print(f"  wrote {args.plot}")
    return 0


_WHIRL_MARKS = {"forward": "F", "backward": "B", "mixed": "M", "none": "-"}


def _speeds(text: str) -> Any:
    """``A:B:N`` as N spin speeds from A to B (rad/s)."""
    import numpy as np

    parts = text.split(":")
    try:
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
        ok = len(parts) == 3 and np.isfinite([a, b]).all() and n >= 1 and (n == 1 or b > a)
    except (ValueError, IndexError):
        ok = False
    if not ok:
        raise ModelError(f"--speed: {text!r} is not valid; expected A:B:N (N >= 1 speeds from A "
                         "to B > A, rad/s)")
    return np.linspace(a, b, n)


def _campbell(args: argparse.Namespace, mf: Any) -> int:
    """The Campbell diagram of ``args.speed`` (``main`` with ``--speed``)."""
    from vibroimpact.rotor import campbell, plot_campbell, translation_pairs

    speeds = _speeds(args.speed)
    structure = mf.model.structure
    owner = getattr(mf, "beam", None) or getattr(mf, "fe", None)
    pairs = translation_pairs(getattr(owner, "dof_map", None), structure.n_dof)
    diagram = campbell(structure, speeds, args.modes, pairs)
    if args.plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        plot_campbell(diagram).savefig(args.plot, dpi=120, bbox_inches="tight")
    if args.json:
        json.dump({"n_dof": structure.n_dof, **diagram.to_dict()}, sys.stdout)
        sys.stdout.write("\n")
        return 0
    print(f"{Path(args.model).name}: Campbell diagram, {structure.n_dof} DOFs, "
          f"{args.modes} modes (frequency Hz, whirl F forward, B backward, M mixed, - none)")
    print(f"  {'speed [rad/s]':>13}  " + "  ".join(f"{'mode ' + str(j + 1):>12}"
                                                  for j in range(args.modes)))
    for i, w in enumerate(diagram.speeds):
        marks = [_WHIRL_MARKS[w] for w in diagram.whirl[i]]
        cells = [f"{f:>10.5g} {mark}" for f, mark in zip(diagram.frequencies_hz[i], marks,
                                                           strict=True)]
        print(f"  {w:>13.6g}  " + "  ".join(f"{c:>12}" for c in cells))
    if args.plot is not None:
        print(f"  wrote {args.plot}")
    return 0
