"""``vibroimpact reproduce``: the paper's cases. Its flags and its work belong to the paper's
reproduction (:mod:`vibroimpact.paper.reproduce`), imported only when the command runs."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("reproduce", help="reproduce one of the paper's cases", add_help=False)
    p.set_defaults(handler=main, forwards_arguments=True)


def main(args: argparse.Namespace) -> int:
    from vibroimpact.paper.reproduce import main as reproduce  # the CLI's seam to the harness

    return reproduce(args.arguments)
