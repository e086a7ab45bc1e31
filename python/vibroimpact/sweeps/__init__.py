"""Parameter sweeps, bifurcation diagrams and response curves at scale: many variants of a
model run in parallel in the compiled core (GIL released), in this process or on a Dask
cluster, reduced while they run to Poincaré samples, peaks, RMS and impact statistics.

    import numpy as np
    import vibroimpact as vi
    from vibroimpact.sweeps import Param, Sweep, run_sweep, plot_bifurcation

    mf = vi.load_model("examples/models/impact_oscillator.toml")
    sweep = Sweep.from_model_file(mf, [Param("loads.0.frequency", np.linspace(5, 50, 400))],
                                  transient=200, periods=100)
    ds = run_sweep(sweep, output="sweep.nc")
    plot_bifurcation(ds, path="bifurcation.png")

The command line: ``vibroimpact sweep MODEL.toml --param loads.0.frequency=5:50:400
--transient 200 --periods 100 -o sweep.nc`` and ``vibroimpact plot sweep.nc --kind
bifurcation -o fig.png``. See ``docs/sweeps.md``.
"""

from vibroimpact.sweeps.grid import Param, apply, numeric_paths, parse_param
from vibroimpact.sweeps.plot import SWEEP_KINDS, plot_bifurcation, plot_response
from vibroimpact.sweeps.runner import (
    CONTINUATIONS,
    ChunkEvent,
    Sweep,
    compute_chunk,
    load_sweep,
    run_sweep,
    save_sweep,
)

__all__ = [
    "CONTINUATIONS",
    "SWEEP_KINDS",
    "ChunkEvent",
    "Param",
    "Sweep",
    "apply",
    "compute_chunk",
    "load_sweep",
    "numeric_paths",
    "parse_param",
    "plot_bifurcation",
    "plot_response",
    "run_sweep",
    "save_sweep",
]
