"""The paper's SDOF case (0.02 s at dt = 1 µs) through the Python API against SciPy DOP853
with contact events, in one process. Same as ``vibroimpact bench``; run with
``python benchmarks/bench_sdof.py [REPEATS]``."""

from __future__ import annotations

import json
import sys

from vibroimpact.benchmarks.sdof import sdof_benchmark

if __name__ == "__main__":
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    for row in sdof_benchmark(repeats=repeats):
        print(json.dumps(row))
