"""Issue 6's speed targets as functions that ``vibroimpact bench`` can print (never used in
tests):

* :func:`hollow_shaft_benchmark` — the hollow shaft, 20 Timoshenko elements (42 DOFs), with
  its load and sliders, at dt = 1 µs; target: 1 s simulated (10⁶ steps) in under 1 s.
* :func:`imported_model_benchmark` — a 2,004-DOF model read from ABAQUS ``.mtx`` files (a
  free–free 3-D tube, 333 elements) with 6 gaps; target: cost per step within 3× of the
  linear-only run of the same model. Also times its Craig–Bampton reduction.
* :func:`solid_model_benchmark` (issue 23) — a 49,980-DOF block of hexahedra
  (:func:`hexahedral_block`) with a gap at its tip; target: a step within 2× of the bare
  forward and backward substitution with its own factor (the floor, timed in the same run).
  :func:`solid_reduction_benchmark` — the block against a stop over a contact patch
  (:func:`solid_patch_model`) and its Craig–Bampton reduction to the patch DOFs plus 50
  modes; target: within 1e-3 of the full model's gap response at a small fraction of the cost.
* :func:`calculix_benchmark` (issue 23) — the 1,140-DOF C3D20 cantilever exported by CalculiX
  (:func:`vibroimpact.benchmarks.calculix.brick_mesh`) with a one-sided gap at its tip,
  against CalculiX's own ``*DYNAMIC, DIRECT`` on the same model without contact, run side by
  side; target: a step ≥ 100× faster.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["calculix_benchmark", "hexahedral_block", "hollow_shaft_benchmark",
           "imported_model_benchmark", "solid_model", "solid_model_benchmark", "solid_patch_model",
           "solid_reduction_benchmark"]

CANTILEVER_ELEMENTS = (20, 1, 2)
CANTILEVER_SIZE = (0.5, 0.02, 0.04)


def hollow_shaft_benchmark(t_end: float = 1.0, dt: float = 1e-6) -> dict[str, Any]:
    """Wall time of the hollow shaft (forced, with sliders) and of the same model without
    gaps, both ``t_end`` at ``dt``; per-step costs in µs."""
    from vibroimpact.model import Model
    from vibroimpact.paper import cases
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


def hexahedral_block(
    n_elements: tuple[int, int, int] = (85, 13, 13),
    size: tuple[float, float, float] = (0.5, 0.06, 0.06),
    youngs_modulus: float = 207e9,
    poisson: float = 0.3,
    density: float = 7850.0,
) -> Any:
    """A steel block of trilinear hexahedra (8 nodes, 2×2×2 Gauss points, consistent mass)
    on a regular grid, clamped at ``x = 0``, assembled with ``scipy.sparse``: the default is
    49,980 DOFs (86 × 14 × 14 nodes, the clamped face removed). Nodes are numbered from 1,
    ``x`` slowest; returns an :class:`~vibroimpact.fe.FEStructure` with its DOF map."""
    import scipy.sparse as sp

    from vibroimpact.fe.dofs import DofMap, FEStructure

    ex, ey, ez = n_elements
    h = np.array(size) / np.array(n_elements)
    lam = youngs_modulus * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = youngs_modulus / (2 * (1 + poisson))
    d = np.full((3, 3), lam) + 2 * mu * np.eye(3)
    d = np.block([[d, np.zeros((3, 3))], [np.zeros((3, 3)), mu * np.eye(3)]])
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]) * 2 - 1
    ke, me = np.zeros((24, 24)), np.zeros((24, 24))
    g = 1 / np.sqrt(3)
    for xi in corners * g:
        n = np.prod(1 + corners * xi, axis=1) / 8
        dn = np.stack([corners[:, a] * np.prod(1 + np.delete(corners, a, 1)
                                                * np.delete(xi, a), axis=1) / 8
                       for a in range(3)], axis=1) * (2 / h)  # dN/dx, dN/dy, dN/dz
        b = np.zeros((6, 24))
        for a in range(3):
            b[a, a::3] = dn[:, a]
        for row, (p, q) in zip((3, 4, 5), ((0, 1), (1, 2), (0, 2)), strict=True):
            b[row, p::3], b[row, q::3] = dn[:, q], dn[:, p]
        det = np.prod(h) / 8
        ke += b.T @ d @ b * det
        nn = np.zeros((3, 24))
        for a in range(3):
            nn[a, a::3] = n
        me += density * nn.T @ nn * det
    nodes = np.arange((ex + 1) * (ey + 1) * (ez + 1)).reshape(ex + 1, ey + 1, ez + 1)
    first = nodes[:-1, :-1, :-1].ravel()
    offsets = np.array([nodes[i, j, k] for i, j, k in corners.clip(0)])
    conn = first[:, None] + offsets[None, :]  # element x corner
    dofs = (conn[:, :, None] * 3 + np.arange(3)).reshape(len(first), 24)
    rows = np.repeat(dofs, 24, axis=1).ravel()
    cols = np.tile(dofs, (1, 24)).ravel()
    n_all = nodes.size * 3
    free = np.arange(3 * nodes[1:].min(), n_all)  # the nodes of x = 0 are clamped

    def assemble(e: np.ndarray) -> sp.csr_array:
        a = sp.csr_array((np.tile(e.ravel(), len(first)), (rows, cols)), shape=(n_all, n_all))
        a.sum_duplicates()
        return a[free][:, free].tocsr()

    labels = np.repeat(np.arange(nodes.size) + 1, 3)[free]
    directions = np.tile(["x", "y", "z"], nodes.size)[free]
    return FEStructure(assemble(me), assemble(ke),
                       dof_map=DofMap(labels.tolist(), directions.tolist()))


def solid_model(n_elements: tuple[int, int, int] = (85, 13, 13)) -> tuple[Any, Any]:
    """(model, gap) of the solid benchmarks: :func:`hexahedral_block` with a one-sided Hertz
    gap at the tip's centre node (``y``, 5 µm) and every node moving at 1 m/s towards it."""
    import vibroimpact as vi

    fe = hexahedral_block(n_elements)
    ex, ey, ez = n_elements
    tip = ex * (ey + 1) * (ez + 1) + (ey // 2) * (ez + 1) + ez // 2 + 1
    gap = fe.gap(vi.contact.Hertz(stiffness=1.5e11), node=tip, direction="y",
                 clearance=5e-6, side="positive")
    v0 = np.zeros(fe.n_dof)
    v0[fe.dofs("all", "y")] = 1.0
    return vi.Model(fe.to_structure(), gaps=[gap], initial_velocity=v0), gap


def solid_patch_model(n_elements: tuple[int, int, int] = (85, 13, 13)) -> tuple[Any, Any]:
    """(model, gap) of the Craig–Bampton benchmark: :func:`hexahedral_block` against a stop
    over a contact patch, as an engineer models a contact on a solid. The gap is the mean
    ``y`` displacement of the patch's nodes (``u = Σ x_j / n``, a one-sided Hertz law of
    K = 1.5e11 N/m^1.5, 5 µm): the top face (``y`` = height) over the last two elements along
    ``x`` and the middle two (even ``ez``) or three (odd ``ez``) across ``z``: 12 nodes,
    11.8 × 13.8 mm, on the default block. The block starts undeformed, moving at 1 m/s
    towards the stop in the shape of its static response to a unit patch displacement (the
    patch's constraint mode: the free end swinging into the stop), a state that every
    Craig–Bampton basis keeping the patch DOFs holds exactly."""
    import vibroimpact as vi
    from vibroimpact.fe.reduction import craig_bampton

    fe = hexahedral_block(n_elements)
    ex, ey, ez = n_elements
    nodes = np.arange((ex + 1) * (ey + 1) * (ez + 1)).reshape(ex + 1, ey + 1, ez + 1) + 1
    across = range(max(ez // 2 - 1, 0), min(ez // 2 + 1 + ez % 2, ez) + 1)
    patch = nodes[ex - 2:, ey, list(across)].ravel()
    dofs = [fe.dof(int(n), "y") for n in patch]
    gap = vi.Gap(dof=dofs, coefficients=[1.0 / len(dofs)] * len(dofs),
                 law=vi.contact.Hertz(stiffness=1.5e11), clearance=5e-6, side="positive",
                 name="patch.y")
    structure = fe.to_structure()
    v0 = craig_bampton(structure, dofs, 0).transform.sum(axis=1)
    return vi.Model(structure, gaps=[gap], initial_velocity=v0), gap


def solid_model_benchmark(steps: int = 20, dt: float = 1e-6,
                          n_elements: tuple[int, int, int] = (85, 13, 13)) -> dict[str, Any]:
    """Per-step cost of :func:`solid_model` (Newmark, average acceleration; the gap closes
    in the sixth step), against the floor: the same run's effective
    stiffness, factorised as the run factorises it, in ``steps`` bare solves
    (``_core.substitution_time``). The steps are timed by the arrival of their rows (streamed
    one by one; the core is polled every 50 ms), so that the setup (ordering, factorisation,
    gap shapes) is left out. The contact is not resolved at this step (a warning the
    benchmark silences): it times steps, not the impact."""
    import warnings

    import vibroimpact as vi
    from vibroimpact import _core
    from vibroimpact.errors import ContactResolutionWarning

    t0 = time.perf_counter()
    model, gap = solid_model(n_elements)
    out: dict[str, Any] = {"n_dof": model.n_dof, "assembly_s": time.perf_counter() - t0,
                           "steps": steps}
    arrivals: list[tuple[float, int]] = []  # (when, rows received by then)
    contact_rows = 0

    def on_rows(block: dict[str, Any]) -> None:
        nonlocal contact_rows
        received = (arrivals[-1][1] if arrivals else 0) + len(block["time"])
        arrivals.append((time.perf_counter(), received))
        contact_rows += int(np.count_nonzero(block["gap_force"][:, 0]))

    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ContactResolutionWarning)
        r = vi.simulate(model, t_end=(steps + 1) * dt, dt=dt, dofs=[gap.dof],
                        on_rows=on_rows, chunk_rows=1)
    # row 0 is the initial state; the first block with row 1 comes after the setup
    first = next(a for a in arrivals if a[1] >= 2)
    last = arrivals[-1]
    out["setup_s"] = first[0] - started
    out["ms_per_step"] = (last[0] - first[0]) / max(last[1] - first[1], 1) * 1e3
    out["contact_steps"] = contact_rows + int(np.count_nonzero(r.gap_force[:, 0]))
    out["newton_iterations"] = r.stats.newton_iterations
    spec = model._run_spec()
    spec.update(vi.Newmark()._run_spec(), t_end=(steps + 1) * dt, dt=dt, every=1,
                record_dofs=[gap.dof], adaptive=None)
    floor = _core.substitution_time(spec, steps)
    out.update(solver=floor["solver"], stored_values=floor["stored_values"],
               floor_ms=floor["solve_s"] * 1e3)
    out["ratio"] = out["ms_per_step"] / max(out["floor_ms"], 1e-12)
    return out


def calculix_benchmark(steps: int = 2000, ccx_steps: int = 30, dt: float = 1e-6
                       ) -> dict[str, Any] | None:
    """Per-step cost of the C3D20 steel cantilever of issue 23 (0.5 × 0.02 × 0.04 m, 20 × 1 × 2
    bricks, 393 nodes, 1,140 DOFs, clamped at ``x = 0``; every free node starts at 1 m/s in
    ``y``), exported by ``ccx`` and imported, with a one-sided Hertz gap in ``y`` at the tip's
    centre node (5 µm: it closes in the sixth step), Newmark at ``dt`` (``steps`` steps; the
    setup left out by also timing 1 step), against ``ccx``'s ``*DYNAMIC, DIRECT`` of the same
    model without the gap at the same ``dt`` (printing the tip's displacement each step, as we
    record the gap DOF), timed as the difference of a 1-step and a ``1 + ccx_steps``-step run
    (the start, reading and first factorisation left out) on one OpenMP thread, as the core
    runs. ``None`` without ``ccx`` on PATH."""
    import shutil
    import warnings

    import vibroimpact as vi
    from vibroimpact import _core
    from vibroimpact.benchmarks.calculix import EXPORT_STEP, brick_mesh, run_ccx
    from vibroimpact.errors import ContactResolutionWarning
    from vibroimpact.fe.matrices import read_calculix

    if shutil.which("ccx") is None:
        return None
    mesh = brick_mesh("C3D20", CANTILEVER_ELEMENTS, CANTILEVER_SIZE)
    clamped = mesh.model + "*BOUNDARY\nFIXED, 1, 3\n"
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        fe = read_calculix(run_ccx(folder, "export", clamped + "*STEP\n" + EXPORT_STEP
                                   + "*END STEP\n"))
        ccx_s, printed = [], []
        for n in (1, 1 + ccx_steps):
            deck = (clamped + "*INITIAL CONDITIONS, TYPE=VELOCITY\nMOVING, 2, 1.0\n"
                    f"*STEP, INC={n + 1}\n*DYNAMIC, DIRECT\n{dt!r}, {n * dt!r}\n"
                    "*NODE PRINT, NSET=TIP\nU\n*END STEP\n")
            t0 = time.perf_counter()
            job = run_ccx(folder, f"dynamic{n}", deck, threads=1)
            ccx_s.append(time.perf_counter() - t0)
            printed.append(job.with_suffix(".dat").read_text().count("displacements"))
    if printed != [1, 1 + ccx_steps]:
        raise RuntimeError(f"ccx *DYNAMIC, DIRECT: printed {printed} increments; expected "
                           f"[1, {1 + ccx_steps}] (fixed increments of {dt:g} s)")
    gap = fe.gap(vi.contact.Hertz(stiffness=1.5e11), node=mesh.tip, direction="y",
                 clearance=5e-6, side="positive")
    v0 = np.zeros(fe.n_dof)
    v0[fe.dofs("all", "y")] = 1.0
    model = vi.Model(fe.to_structure(), gaps=[gap], initial_velocity=v0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ContactResolutionWarning)
        one = vi.simulate(model, t_end=dt, dt=dt, dofs=[gap.dof]).stats.wall_time_s
        r = vi.simulate(model, t_end=(steps + 1) * dt, dt=dt, dofs=[gap.dof])
    spec = model._run_spec()
    spec.update(vi.Newmark()._run_spec(), t_end=(steps + 1) * dt, dt=dt, every=1,
                record_dofs=[gap.dof], adaptive=None)
    solver = _core.substitution_time(spec, 1)["solver"]
    ms_per_step = max(r.stats.wall_time_s - one, 0.0) / steps * 1e3
    ccx_ms = (ccx_s[1] - ccx_s[0]) / ccx_steps * 1e3
    return {"n_dof": fe.n_dof, "steps": steps, "solver": solver, "ms_per_step": ms_per_step,
            "contact_steps": int(np.count_nonzero(r.gap_force[:, 0])),
            "ccx_steps": ccx_steps, "ccx_ms_per_step": ccx_ms, "ccx_setup_s": ccx_s[0],
            "speedup": ccx_ms / max(ms_per_step, 1e-12)}


def solid_reduction_benchmark(steps: int = 2000, n_modes: Sequence[int] = (50, 100, 200),
                              dt: float = 5e-7,
                              n_elements: tuple[int, int, int] = (85, 13, 13),
                              time_error: bool = False,
                              select: Sequence[str] = ("frequency",),
                              candidates: int | None = None) -> Iterator[dict[str, Any]]:
    """:func:`solid_patch_model` reduced by Craig–Bampton to its patch DOFs plus each of
    ``n_modes`` fixed-interface modes, chosen by each way of ``select`` (``candidates``: see
    :func:`~vibroimpact.fe.reduction.craig_bampton`), against one full run of ``steps``
    Newmark steps of ``dt`` (both from the same state, which every basis holds exactly).
    Yields one row per reduction: the gap displacement's (``u``, the patch's mean) and
    contact force's largest errors over the history relative to their largest values
    (``contact_displacement_error``: ``u``'s over the steps in contact, relative to its
    largest value in contact; the largest ``|u|`` of a run is reached in the free swing
    after the block leaves the stop), the reduction's time and the reduced run's against the
    full run's (the core's times, setup included; ``reduction_s / full_ms_per_step`` full
    steps pay for the reduction).

    With ``time_error``, a last row with the full model's own error of time discretisation:
    ``full_time_error``, its ``u`` at ``dt`` against a run at ``dt / 2`` (compared at the
    steps of ``dt``, relative to the largest ``u``): the scale below which a reduction error
    says nothing about the continuous model. Twice the full run's cost."""
    import warnings

    from vibroimpact.errors import ContactResolutionWarning
    from vibroimpact.fe.reduction import craig_bampton
    from vibroimpact.simulate import simulate

    model, gap = solid_patch_model(n_elements)
    patch, weights = list(gap.dofs), np.asarray(gap.coefficients)

    def run(m: Any, dofs: list[int], step: float) -> Any:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ContactResolutionWarning)
            return simulate(m, steps * dt, step, dofs=dofs, every=round(dt / step))

    full = run(model, patch, dt)
    u_full, f_full = full.displacement @ weights, full.gap_force[:, 0]
    u_peak, f_peak = float(np.abs(u_full).max()), float(np.abs(f_full).max())
    in_contact = f_full > 0
    u_contact_peak = float(np.abs(u_full[in_contact]).max()) if in_contact.any() else u_peak
    for how, n in ((how, n) for how in select for n in n_modes):
        t0 = time.perf_counter()
        cb = craig_bampton(model, patch, n, select=how,
                           candidates=None if how == "frequency" else candidates)
        reduction_s = time.perf_counter() - t0
        red = run(cb.reduce_model(model), [cb.reduced_dof(d) for d in patch], dt)
        u_error = np.abs(red.displacement @ weights - u_full)
        yield {"n_dof": model.n_dof, "patch_nodes": len(patch), "reduced_n_dof": cb.n_dof,
               "n_modes": n, "select": how, "candidates": cb.candidates, "dt": dt, "steps": steps,
               "max_interior_hz": float(cb.interior_frequencies_hz[-1]) if n else 0.0,
               "contact_steps": int(np.count_nonzero(f_full)),
               "impacts": len(full.impacts), "impacts_reduced": len(red.impacts),
               "displacement_error": float(u_error.max() / u_peak),
               "contact_displacement_error": float(u_error[in_contact].max(initial=0.0)
                                                   / u_contact_peak),
               "force_error": float(np.abs(red.gap_force[:, 0] - f_full).max() / f_peak),
               "reduction_s": reduction_s, "reduced_run_s": red.stats.wall_time_s,
               "full_run_s": full.stats.wall_time_s,
               "full_ms_per_step": full.stats.wall_time_s / steps * 1e3,
               "cost_fraction": (reduction_s + red.stats.wall_time_s)
               / max(full.stats.wall_time_s, 1e-12)}
    if time_error:
        fine = run(model, patch, dt / 2).displacement @ weights
        k = min(fine.size, u_full.size)
        yield {"dt": dt, "steps": steps,
               "full_time_error": float(np.abs(fine[:k] - u_full[:k]).max() / u_peak)}
