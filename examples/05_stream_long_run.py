"""A long run streamed to disk: the two-mass chain of example 02 shaken for 20 s at dt = 10 µs
(2 million steps). The core hands the recorded rows over every 200,000 steps while it runs and
each block is appended to a NetCDF file, so memory holds a few blocks, not the run. The file
appears, complete, at the end.

    python examples/05_stream_long_run.py [OUTPUT_FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import vibroimpact as vi
from vibroimpact.io import results_file

out = Path(sys.argv[1] if len(sys.argv) > 1 else "example-output")
out.mkdir(parents=True, exist_ok=True)

structure = vi.Structure(mass=[[1.0, 0.0], [0.0, 0.5]],
                         stiffness=[[1500.0, -500.0], [-500.0, 500.0]],
                         damping=[[0.3, -0.1], [-0.1, 0.1]])
law = vi.contact.HuntCrossley(stiffness=1e9, restitution=0.8)
model = vi.Model(structure,
                 gaps=[vi.Gap(dof=[0, 1], coefficients=[1.0, -1.0], clearance=0.001,
                              side="both", law=law)],
                 loads=[vi.HarmonicLoad(dof=1, amplitude=5.0, frequency=5.0)])


def progress(fraction: float) -> None:
    print(f"\r{100 * fraction:5.1f} %", end="", file=sys.stderr, flush=True)


summary = results_file.simulate_to_file(model, out / "long.nc", t_end=20.0, dt=1e-5, every=20,
                                        window_steps=200_000, progress=progress)
print(file=sys.stderr)
print(f"{summary['steps']} steps written in {summary['windows']} blocks, "
      f"{len(summary['impacts'])} contacts, {summary['wall_time_s']:.2f} s in the core")
ds = results_file.load(out / "long.nc")
print(f"long.nc: {ds.sizes['time']} samples, {ds.sizes['impact']} contacts")
