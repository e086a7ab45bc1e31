"""The sweep benchmark of issue 8: 400 forcing frequencies x 300 forcing periods of the SDOF
impact oscillator (Lankarani-Nikravesh stop, adaptive Newmark), in this process on 1 and 2
threads and on a Dask LocalCluster of 2 workers. Same as the sweep rows of
``vibroimpact bench``; run with ``python benchmarks/bench_sweep.py [POINTS] [--json]``."""

from __future__ import annotations

import json
import sys

from vibroimpact.benchmarks.sweep import format_rows, sweep_benchmark

if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    points = int(args[0]) if args else 400
    rows = sweep_benchmark(points=points, dask="--no-dask" not in sys.argv)
    if "--json" in sys.argv:
        for row in rows:
            print(json.dumps(row))
    else:
        print("\n".join(format_rows(rows)))
