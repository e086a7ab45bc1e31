"""The large-model benchmark of issue 23: a 49,980-DOF steel block of hexahedra (generated
here by :func:`vibroimpact.benchmarks.large_models.hexahedral_block`, nothing committed)
with a gap at its tip, its cost per Newmark step against the bare forward and backward
substitution with its own factor. Same as the solid row of ``vibroimpact bench``; run with
``python benchmarks/bench_solid.py [STEPS] [--json]``."""

from __future__ import annotations

import json
import sys

from vibroimpact.benchmarks.large_models import solid_model_benchmark

if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    row = solid_model_benchmark(steps=int(args[0]) if args else 20)
    if "--json" in sys.argv:
        print(json.dumps(row))
    else:
        for key, value in row.items():
            print(f"{key:16s} {value}")
