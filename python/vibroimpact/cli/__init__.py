"""The ``vibroimpact`` command line. Each subcommand lives in its own module with
``add_parser(subparsers)`` and ``main(args) -> int``; this module only dispatches and turns
user mistakes into one-line errors (exit code 2), solver failures into exit code 3 and
interruptions (:class:`~vibroimpact.Interrupted`) into 130 (SIGINT) or 143 (SIGTERM).

``reproduce`` and ``bench`` run the research harness (the paper's reproduction,
:mod:`vibroimpact.paper`; the benchmarks and peer drivers, :mod:`vibroimpact.benchmarks`),
which the engine never imports: their modules here only name the command
(``forwards_arguments``), and their ``main`` imports the harness when the command runs and
hands it the command's arguments, which it parses itself. That lazy import is the command
line's one seam to the harness (``tests/test_layers.py`` holds it to that).

No library's warning text reaches the terminal: a warning of vibroimpact's own
(:class:`~vibroimpact.ContactResolutionWarning`, ``CondensationWarning``) is printed as
``vibroimpact: warning: <its message>``, and one that escapes from a library (numpy, SciPy,
matplotlib, xarray, dask: each known cause is prevented where it arises) as one line saying
where it came from, never Python's ``file:line: Category: text`` with its source line. Log
records of other libraries at WARNING and above are printed the same way."""

from __future__ import annotations

import argparse
import logging
import sys
import warnings
from collections.abc import Sequence
from typing import Any, TextIO

from vibroimpact.cli.verbosity import command_logging
from vibroimpact.errors import Interrupted, ModelError, SolverError

__all__ = ["main"]


def _build_parser() -> argparse.ArgumentParser:
    from vibroimpact.cli import (
        bench,
        continuation,
        impact,
        laws,
        modal,
        orbit,
        plot,
        reproduce,
        run,
        sweep,
    )

    parser = argparse.ArgumentParser(
        prog="vibroimpact",
        description="Dynamic response of structures with clearance (vibro-impact).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (run, impact, laws, reproduce, modal, plot, sweep, orbit, continuation, bench):
        module.add_parser(sub)
    return parser


def _module_of(filename: str) -> str:
    """The dotted name of the module imported from ``filename`` (else the file's stem)."""
    for module in list(sys.modules.values()):
        if getattr(module, "__file__", None) == filename:
            return str(module.__name__)
    return filename.replace("\\", "/").rsplit("/", 1)[-1].removesuffix(".py")


def warning_line(message: Warning | str, category: type[Warning], filename: str) -> str:
    """The one line that the command line prints for a warning: vibroimpact's own as its
    message, a library's as where it arose (module, not path) and what it said."""
    text = " ".join(str(message).split())
    if category.__module__.split(".")[0] == "vibroimpact":
        return f"vibroimpact: warning: {text}"
    where = _module_of(filename)
    return (f"vibroimpact: warning: a computation in {where} reported a problem ({text}); the "
            "results may be affected: please report it")


def _show_warning(message: Warning | str, category: type[Warning], filename: str,
                  lineno: int, file: TextIO | None = None, line: str | None = None) -> None:
    print(warning_line(message, category, filename), file=sys.stderr if file is None else file)


class _LibraryLogHandler(logging.Handler):
    """Prints another library's log records (WARNING and above) as our one-line warnings."""

    def emit(self, record: logging.LogRecord) -> None:
        text = " ".join(record.getMessage().split())
        print(f"vibroimpact: warning: {record.name}: {text}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vibroimpact`` script."""
    parser = _build_parser()
    args, rest = parser.parse_known_args(argv)
    if getattr(args, "forwards_arguments", False):
        args.arguments = rest
    elif rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    root = logging.getLogger()
    handler = _LibraryLogHandler(logging.WARNING)
    root.addHandler(handler)
    try:
        with warnings.catch_warnings(), command_logging():
            warnings.showwarning = _show_warning
            return _dispatch(args)
    finally:
        root.removeHandler(handler)


def _dispatch(args: Any) -> int:
    """Run the subcommand; map the project's errors to one line and an exit code."""
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
