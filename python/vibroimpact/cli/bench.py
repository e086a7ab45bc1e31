"""``vibroimpact bench``: the speed benchmarks. Their flags and their work belong to the
benchmarks (:mod:`vibroimpact.benchmarks.command`), imported only when the command runs."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="time the engine against SciPy on the paper's cases",
                       add_help=False)
    p.set_defaults(handler=main, forwards_arguments=True)


def main(args: argparse.Namespace) -> int:
    from vibroimpact.benchmarks.command import main as bench  # the CLI's seam to the harness

    return bench(args.arguments)
