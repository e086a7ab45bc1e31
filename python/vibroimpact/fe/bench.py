"""Issue 6's speed targets as functions that ``vibroimpact bench`` can print (never used in
tests):

* :func:`hollow_shaft_benchmark` — the hollow shaft, 20 Timoshenko elements (42 DOFs), with
  its load and sliders, at dt = 1 µs; target: 1 s simulated (10⁶ steps) in under 1 s.
* :func:`imported_model_benchmark` — a 2,004-DOF model read from ABAQUS ``.mtx`` files (a
  free–free 3-D tube, 333 elements) with 6 gaps; target: cost per step within 3× of the
  linear-only run of the same model. Also times its Craig–Bampton reduction.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["hollow_shaft_benchmark", "imported_model_benchmark"]


def hollow_shaft_benchmark(t_end: float = 1.0, dt: float = 1e-6) -> dict[str, Any]:
    """Wall time of the hollow shaft (forced, with sliders) and of the same model without
    gaps, both ``t_end`` at ``dt``; per-step costs in µs."""
    from vibroimpact import cases
    from vibroimpact.model import Model
    from vibroimpact.simulate import simulate

    model = cases.hollow_shaft_model("timoshenko", 20)
    rec = [g.dof for g in model.gaps]
    out: dict[str, Any] = {"n_dof": model.n_dof, "t_end": t_end, "dt": dt}
    for label, m in (("gaps", model), ("linear", Model(model.structure, loads=model.loads))):
        r = simulate(m, t_end=t_end, dt=dt, dofs=rec, every=1000)
        out[f"{label}_wall_time_s"] = r.stats.wall_time_s
        out[f"{label}_us_per_step"] = r.stats.wall_time_s / r.stats.steps * 1e6
        out["steps"] = r.stats.steps
    return out


def imported_model_benchmark(steps: int = 2000, n_modes: int = 60) -> dict[str, Any]:
    """Per-step cost of a 2,004-DOF imported model with 6 gaps against its linear-only run
    (``steps`` steps of 1 µs each; the core's setup is timed apart by also running 1 step;
    the banded setup of 2,004 DOFs takes under a second),
    and of its Craig–Bampton reduction to the gap DOFs + ``n_modes`` modes."""
    import vibroimpact as vi
    from vibroimpact.fe.beam import Beam, Material, Section
    from vibroimpact.fe.matrices import read_abaqus, write_abaqus_mtx
    from vibroimpact.fe.reduction import craig_bampton

    beam = Beam(1.0, 333, Section.tube(0.19, 0.005), Material(207e9, 0.3, 7850.0),
                dofs_per_node=6)
    with tempfile.TemporaryDirectory() as d:
        k_path, m_path = Path(d) / "job_STIF1.mtx", Path(d) / "job_MASS1.mtx"
        write_abaqus_mtx(k_path, beam.fe.stiffness, beam.dof_map)
        write_abaqus_mtx(m_path, beam.fe.mass, beam.dof_map)
        t0 = time.perf_counter()
        fe = read_abaqus(k_path, m_path)
        read_s = time.perf_counter() - t0
    law = vi.contact.Hertz(stiffness=1.5e11)
    gaps = [fe.gap(law, node=n, direction=d, clearance=1e-4, side="both")
            for n in (0, 166, 333) for d in ("x", "y")]
    v0 = np.zeros(fe.n_dof)
    v0[fe.dofs("all", "x")] = 0.5
    v0[fe.dofs("all", "y")] = 0.3
    rec = [g.dof for g in gaps]
    out: dict[str, Any] = {"n_dof": fe.n_dof, "gaps": len(gaps), "read_s": read_s}
    structure = fe.to_structure()
    for label, g in (("linear", []), ("gaps", gaps)):
        m = vi.Model(structure, gaps=g, initial_velocity=v0)
        one = vi.simulate(m, t_end=1e-6, dt=1e-6, dofs=rec).stats.wall_time_s
        many = vi.simulate(m, t_end=(steps + 1) * 1e-6, dt=1e-6, dofs=rec).stats.wall_time_s
        out[f"{label}_setup_s"] = one
        out[f"{label}_ms_per_step"] = max(many - one, 0.0) / steps * 1e3
    out["ratio"] = out["gaps_ms_per_step"] / max(out["linear_ms_per_step"], 1e-12)
    t0 = time.perf_counter()
    cb = craig_bampton(fe, [*rec, fe.dof(0, "z"), fe.dof(0, "rz")], n_modes)
    out["reduction_s"] = time.perf_counter() - t0
    red = cb.model(gaps, initial_velocity=v0)
    out["reduced_n_dof"] = red.n_dof
    for label, g in (("reduced_linear", []), ("reduced_gaps", red.gaps)):
        m = vi.Model(red.structure, gaps=g, initial_velocity=red.initial_velocity)
        r = vi.simulate(m, t_end=0.02, dt=1e-6, dofs=list(range(len(rec))))
        out[f"{label}_us_per_step"] = r.stats.wall_time_s / r.stats.steps * 1e6
    return out
