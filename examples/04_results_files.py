"""Result files: save a run as NetCDF-4 and CSV (written atomically), read it back with plain
xarray, rebuild the model from the file and re-run it, and plot from the file.

    python examples/04_results_files.py [OUTPUT_FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import vibroimpact as vi
import xarray as xr
from vibroimpact import plotting
from vibroimpact.io import results_file
from vibroimpact.paper import cases

out = Path(sys.argv[1] if len(sys.argv) > 1 else "example-output")
out.mkdir(parents=True, exist_ok=True)

result = vi.simulate(cases.sdof_model("flores", 0.5), t_end=0.01, dt=1e-6)
result.save(out / "run.nc")          # MATLAB: ncread('run.nc', 'displacement')
files = result.save(out / "run.csv")  # run.csv, run_impacts.csv, run_energy.csv, run_meta.json
print("wrote", ", ".join(p.name for p in [out / "run.nc", *files]))

with xr.open_dataset(out / "run.nc") as ds:
    print(ds["displacement"].attrs["units"], ds.sizes["time"], "samples,",
          ds.sizes["impact"], "contacts; made with", ds.attrs["method"][:40], "...")
    model, method = results_file.model_from_dataset(ds)  # how the file was made
    again = vi.simulate(model, ds.attrs["t_end"], ds.attrs["dt"], method)
    print("re-run from the file reproduces it:",
          bool(np.array_equal(again.displacement, ds["displacement"].values)))

plotting.plot(out / "run.nc", "velocity-indentation", path=out / "rate_from_file.svg")
print(f"wrote {out}/rate_from_file.svg")
