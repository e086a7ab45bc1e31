"""The ``-q/--quiet`` and ``-v/--verbose`` options of the commands that run a model, the
logging they set up, and the verbose account of a run (solver statistics, contacts)."""

from __future__ import annotations

import argparse
import logging
import math
import sys
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any

__all__ = ["LOGGED_CONTACTS", "add_verbosity_options", "command_logging", "configure_logging",
           "log_run"]


def add_verbosity_options(parser: argparse.ArgumentParser) -> None:
    """``-q/--quiet`` (no progress, no summary) and ``-v/--verbose`` (log solver statistics
    and every contact to stderr)."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true",
                       help="print nothing but errors (and --json output)")
    group.add_argument("-v", "--verbose", action="store_true",
                       help="log solver statistics and the contacts to stderr")


_HANDLER: logging.Handler | None = None


@contextmanager
def command_logging() -> Iterator[None]:
    """Gives back the ``vibroimpact`` loggers' level, propagation and handlers after a command:
    a command run in-process (``vibroimpact.cli.main`` from a script, a notebook or a test)
    leaves the caller's logging as it found it, not at ``--verbose``'s INFO."""
    logger = logging.getLogger("vibroimpact")
    level, propagate, handlers = logger.level, logger.propagate, list(logger.handlers)
    try:
        yield
    finally:
        for handler in list(logger.handlers):
            if handler not in handlers:
                logger.removeHandler(handler)
        logger.setLevel(level)
        logger.propagate = propagate


def configure_logging(args: argparse.Namespace) -> None:
    """Send the ``vibroimpact`` loggers to stderr: INFO with ``--verbose``, else WARNING."""
    global _HANDLER
    logger = logging.getLogger("vibroimpact")
    if _HANDLER is not None:
        logger.removeHandler(_HANDLER)
    _HANDLER = logging.StreamHandler(sys.stderr)
    _HANDLER.setFormatter(logging.Formatter("vibroimpact: %(message)s"))
    logger.addHandler(_HANDLER)
    logger.setLevel(logging.INFO if getattr(args, "verbose", False) else logging.WARNING)
    logger.propagate = False


#: Contacts listed one by one in the verbose log (the rest are counted).
LOGGED_CONTACTS = 50


def log_run(logger: logging.Logger, summary: Mapping[str, Any]) -> None:
    """Log a run's solver statistics and its contacts (from :meth:`Result.summary`) at INFO.
    Per-step events (each step cut, each Newton iteration) are not reported by the compiled
    core, only their totals."""
    if not logger.isEnabledFor(logging.INFO):
        return
    steps = max(int(summary["steps"]), 1)
    wall = float(summary["wall_time_s"])
    logger.info("solver: %d steps (dt = %.3g s, t_end = %.6g s), %d rejected, %d step cuts, "
                "step path %s", summary["steps"], summary["dt"], summary["t_end"],
                summary["rejected_steps"], summary["step_cuts"],
                summary["step_path"])
    logger.info("solver: %d Newton iterations (%.3f per step), wall time %.4f s "
                "(%.3g steps/s), energy balance error %.3e",
                summary["newton_iterations"], summary["newton_iterations"] / steps, wall,
                steps / wall if wall > 0 else math.inf, summary["energy_balance_error"])
    impacts = summary["impacts"]
    logger.info("contacts: %d", len(impacts))
    for row in impacts[:LOGGED_CONTACTS]:
        t_end = row["t_end"]
        logger.info(
            "contact: gap %d %s, t = %.6e s .. %s, v_in = %.4g m/s, v_out = %s, "
            "delta_max = %.4g m, force_max = %.4g N",
            row["gap"], row["side"], row["t_start"],
            "open at the end" if t_end is None else f"{t_end:.6e} s",
            row["v_in"], "-" if row["v_out"] is None else f"{row['v_out']:.4g} m/s",
            row["delta_max"] or 0.0, row["force_max"] or 0.0,
        )
    if len(impacts) > LOGGED_CONTACTS:
        logger.info("contact: ... %d more", len(impacts) - LOGGED_CONTACTS)
