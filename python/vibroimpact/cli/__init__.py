"""The ``vibroimpact`` command line. Each subcommand lives in its own module with
``add_parser(subparsers)`` and ``main(args) -> int``; this module only dispatches and turns
user mistakes into one-line errors (exit code 2), solver failures into exit code 3 and
interruptions (:class:`~vibroimpact.Interrupted`) into 130 (SIGINT) or 143 (SIGTERM)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from vibroimpact.errors import Interrupted, ModelError, SolverError

__all__ = ["main"]


def _build_parser() -> argparse.ArgumentParser:
    from vibroimpact.cli import bench, impact, laws, modal, plot, reproduce, run, sweep

    parser = argparse.ArgumentParser(
        prog="vibroimpact",
        description="Dynamic response of structures with clearance (vibro-impact).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (run, impact, laws, reproduce, modal, plot, sweep, bench):
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vibroimpact`` script."""
    parser = _build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args))
    except ModelError as e:
        for line in str(e).splitlines() or [""]:
            print(f"vibroimpact: error: {line}", file=sys.stderr)
        return 2
    except Interrupted as e:
        print(f"vibroimpact: interrupted: {e}", file=sys.stderr)
        return 128 + int(e.signum)
    except SolverError as e:
        print(f"vibroimpact: solver failed: {e}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print("vibroimpact: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
