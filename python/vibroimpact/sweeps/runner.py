"""Parameter sweeps: a grid of model variants run in parallel in the compiled core, in this
process or on a Dask cluster, reduced to Poincaré samples, peaks, RMS and impact statistics,
and returned as an :class:`xarray.Dataset` (docs/sweeps.md).

Example — the bifurcation diagram of an impact oscillator against the forcing frequency::

    import vibroimpact as vi
    from vibroimpact.sweeps import Sweep, Param, run_sweep
    mf = vi.load_model("examples/models/impact_oscillator.toml")
    sweep = Sweep.from_model_file(mf, [Param("loads.0.frequency", np.linspace(5, 50, 400))],
                                  transient=200, periods=100)
    ds = run_sweep(sweep, output="sweep.nc")       # all cores; resumable
    ds.poincare_displacement.sel(dof=0)             # (loads.0.frequency, sample)

How it runs: the model is read once into the core's typed spec (``_core.ModelSpec``); each
point is a copy of it with the swept numbers set by the core (``ModelSpec.with_value``, the
paths of :mod:`vibroimpact.sweeps.grid`); points are grouped in chunks; each chunk is one
call of the core (``_core.sweep``), which runs its points on all cores with the GIL released
and keeps, per point, only what the Dataset holds. Chunks run in this process (two at a time,
so that no core idles at a chunk's end) or as tasks on Dask workers
(:mod:`vibroimpact.sweeps.distributed`). Finished chunks are written to
``OUTPUT.parts/HASH/`` so that a killed sweep restarts where it stopped; ``HASH`` is a digest
of the sweep's definition, so a changed sweep never reuses stale parts.

Continuation (response curves with hysteresis): the points along the first parameter run one
after the other, each starting from the final state ``(x, v)`` of the previous one; ``up``
runs them in the order of the values, ``down`` in reverse, ``both`` does both (a
``direction`` dimension). A long chain is split into chunks that depend on each other.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import math
import os
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

from vibroimpact import _core
from vibroimpact.errors import Interrupted, ModelError, require
from vibroimpact.integrators import Integrator, Newmark
from vibroimpact.io.results_file import atomic_write, netcdf_engine
from vibroimpact.model import Model
from vibroimpact.result import DOF_UNIT_DESCRIPTION, dof_variable_units
from vibroimpact.sweeps.grid import Param

if TYPE_CHECKING:
    import xarray as xr

    from vibroimpact.io.model_file import ModelFile

__all__ = [
    "CONTINUATIONS",
    "DOF_QUANTITIES",
    "SUFFIXES",
    "VARIABLES",
    "ChunkEvent",
    "Sweep",
    "compute_chunk",
    "load_sweep",
    "run_sweep",
    "save_sweep",
]

#: ``continuation`` values.
CONTINUATIONS = ("none", "up", "down", "both")

#: Version of the chunk files (part of the sweep hash).
_FORMAT = 1

#: ``every`` that never records (the core keeps the first and last states only).
_NEVER = 2**62

#: File suffixes the Dataset can be written to.
SUFFIXES = (".nc", ".h5", ".hdf5")


@dataclass(frozen=True)
class Sweep:
    """A sweep definition.

    - ``model``: the model whose numbers are swept; ``params``: one or more :class:`Param`
      (the grid is their Cartesian product, the first varying slowest).
    - ``dt``: step, s (fixed steps: shortened to a whole fraction of each point's forcing
      period so that the samples land on steps; adaptive: the first step).
    - ``method``: integrator (default :class:`~vibroimpact.Newmark`); with adaptive stepping
      and no ``dt_max``, the largest step is a sixteenth of the forcing period.
    - ``transient``, ``periods``: forcing periods discarded, then sampled; each point runs
      ``(transient + periods) T`` with ``T`` the period of load ``period_load`` (default: the
      first harmonic load, or unbalance at the spin speed: ``T = 2π/Ω``).
    - ``dofs``: sampled DOFs (default all when at most 8, else the gaps' DOFs).
    - ``continuation``: ``none``, ``up``, ``down`` or ``both`` (see the module doc).
    - ``max_impacts``: impacts kept per gap and point (speeds and phases; default
      ``periods``, at most 1000).
    - ``chunk_size``: points per chunk (default: about 20 chunks, at most 256 points each).
    - ``samples_per_period``: samples of each sampled period (default 1, the Poincaré
      section; more: the ``sample`` dimension is a time history at ``T / N``, what a rotor's
      full-spectrum waterfall needs: ``vibroimpact plot SWEEP --kind waterfall``).
    """

    model: Model
    params: Sequence[Param]
    dt: float
    method: Integrator | None = None
    transient: int = 100
    periods: int = 100
    dofs: Sequence[int] | None = None
    continuation: str = "none"
    max_impacts: int | None = None
    period_load: int | None = None
    chunk_size: int | None = None
    samples_per_period: int = 1

    def __post_init__(self) -> None:
        require(isinstance(self.model, Model), "model", type(self.model).__name__,
                "a vibroimpact.Model")
        params = tuple(self.params)
        require(len(params) > 0 and all(isinstance(p, Param) for p in params), "--param",
                params, "one or more vibroimpact.sweeps.Param")
        paths = [p.path for p in params]
        dup = sorted({p for p in paths if paths.count(p) > 1})
        require(not dup, "--param", dup[0] if dup else None, "each parameter once")
        object.__setattr__(self, "params", params)
        require(isinstance(self.dt, (int, float)) and not isinstance(self.dt, bool)
                and math.isfinite(self.dt) and self.dt > 0, "solver.dt", self.dt,
                "a step > 0 in s")
        method = Newmark() if self.method is None else self.method
        require(isinstance(method, Integrator), "solver.method", method,
                "a vibroimpact integrator")
        object.__setattr__(self, "method", method)
        for name in ("transient", "periods"):
            v = getattr(self, name)
            low = 1 if name == "periods" else 0
            require(isinstance(v, int) and not isinstance(v, bool) and v >= low,
                    f"--{name}", v, f"an integer >= {low} (forcing periods)")
        require(self.continuation in CONTINUATIONS, "--continuation", self.continuation,
                "one of " + ", ".join(CONTINUATIONS))
        n = self.model.n_dof
        if self.dofs is None:
            gap_dofs = sorted({d for g in self.model.gaps for d in g.dofs})
            dofs = list(range(n)) if n <= 8 or not gap_dofs else gap_dofs
        else:
            dofs = [int(d) for d in self.dofs]
            bad = [d for d in dofs if not 0 <= d < n]
            require(not bad and dofs, "--dof", bad[0] if bad else dofs, f"DOFs 0 <= dof < {n}")
        object.__setattr__(self, "dofs", tuple(dofs))
        mi = min(self.periods, 1000) if self.max_impacts is None else self.max_impacts
        require(isinstance(mi, int) and mi >= 0, "--max-impacts", mi, "an integer >= 0")
        object.__setattr__(self, "max_impacts", mi)
        spp = self.samples_per_period
        require(isinstance(spp, int) and not isinstance(spp, bool) and spp >= 1,
                "--samples-per-period", spp, "an integer >= 1")
        require(self.chunk_size is None or (isinstance(self.chunk_size, int)
                                            and self.chunk_size >= 1),
                "--chunk-size", self.chunk_size, "an integer >= 1")
        loads = self.model.loads
        require(self.period_load is None or (isinstance(self.period_load, int)
                                             and 0 <= self.period_load < len(loads)),
                "--period-load", self.period_load, f"a load index below {len(loads)}")

    @classmethod
    def from_model_file(cls, mf: ModelFile, params: Sequence[Param], **options: Any) -> Sweep:
        """A sweep of a model file's model with its solver (``dt``, method unless ``method``
        is given; ``t_end`` is replaced by the transient and the sampled periods) and its
        output DOFs (of the model that runs: :attr:`~vibroimpact.io.ModelFile.run_dofs`)."""
        options.setdefault("dofs", mf.run_dofs)
        options.setdefault("method", mf.method)
        return cls(model=mf.model, params=params, dt=mf.dt, **options)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(p) for p in self.params)

    @property
    def directions(self) -> tuple[str, ...]:
        return {"none": ("",), "up": ("up",), "down": ("down",),
                "both": ("up", "down")}[self.continuation]

    @property
    def n_points(self) -> int:
        """Runs: grid points times directions."""
        return len(self.directions) * math.prod(self.shape)


@dataclass(frozen=True)
class _Chunk:
    """Jobs run by one core call. ``chains``: job lists run in sequence (continuation);
    ``starts``: ``(job, previous job)`` pairs whose previous job is in chunk ``deps``."""

    index: int
    jobs: tuple[int, ...]
    chains: tuple[tuple[int, ...], ...] | None
    starts: tuple[tuple[int, int], ...]
    deps: tuple[int, ...]


@dataclass(frozen=True)
class _Plan:
    """Everything a worker needs to build and run any job of a sweep (picklable)."""

    base: dict[str, Any]
    integrator: Integrator
    dt: float
    paths: tuple[str, ...]
    values: tuple[np.ndarray, ...]
    transient: int
    periods: int
    dofs: tuple[int, ...]
    max_impacts: int
    period_load: int | None
    directions: tuple[str, ...]
    samples_per_period: int = 1

    @property
    def adaptive(self) -> dict[str, Any] | None:
        """The integrator's adaptive stepping as plain data (``None``: fixed steps)."""
        a = self.integrator.adaptive
        return None if a is None else dataclasses.asdict(a)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(v.size for v in self.values)

    @property
    def n_grid(self) -> int:
        return math.prod(self.shape)

    @property
    def n_jobs(self) -> int:
        return len(self.directions) * self.n_grid

    @functools.cached_property
    def model(self) -> _core.ModelSpec:
        """The model of :attr:`base` as the core's typed spec (read once, per process)."""
        return _core.ModelSpec(self.base)

    def point_model(self, j: int) -> _core.ModelSpec:
        """The model of job ``j`` (its parameters set by the core: ``ModelSpec.with_value``)."""
        index = np.unravel_index(j % self.n_grid, self.shape)
        model = self.model
        for path, values, i in zip(self.paths, self.values, index, strict=True):
            model = model.with_value(path, float(values[i]))
        return model

    def period(self, model: _core.ModelSpec) -> float:
        """The forcing period (s) the sweep counts: load ``period_load``'s, else the first
        periodic load's (a harmonic load, or an unbalance at the spin speed: ``2π/Ω``; the
        core's ``load_frequency``)."""
        frequencies = model.load_frequencies()
        if self.period_load is not None:
            f = frequencies[self.period_load]
            if f <= 0:
                raise ModelError(f"--period-load: load {self.period_load} is not a harmonic "
                                 "load (or an unbalance) with a frequency > 0; expected the "
                                 "load whose period the sweep samples at")
            return 1.0 / f
        for f in frequencies:
            if f > 0:
                return 1.0 / f
        raise ModelError("loads: no harmonic load (or unbalance at a constant spin speed) with "
                         "a frequency > 0; expected one, since --transient and --periods count "
                         "periods of the first such load")

    def job_spec(self, j: int, start: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> dict[str, Any]:
        """The full spec of job ``j`` for the core, starting from ``start`` if given (else
        from the model's initial state)."""
        model = self.point_model(j)
        period = self.period(model)
        spec: dict[str, Any] = {"model": model}
        if start is not None:
            spec["x0"], spec["v0"] = np.asarray(start[0]), np.asarray(start[1])
        # (adaptive stepping's limits: the core's defaults for a sweep, from the period)
        spec.update(
            self.integrator._run_spec(),
            t_end=(self.transient + self.periods) * period,
            dt=self.dt,
            every=_NEVER,
            record_dofs=list(self.dofs),
            sweep={"period": period, "transient": self.transient,
                   "samples": self.periods * self.samples_per_period,
                   "per_period": self.samples_per_period,
                   "dofs": list(self.dofs), "max_impacts": self.max_impacts},
        )
        return spec

    def definition(self) -> dict[str, Any]:
        """JSON-ready description (exact floats) that the sweep hash is taken of."""

        def plain(x: Any) -> Any:
            if isinstance(x, np.ndarray):
                return x.tolist()
            if sp.issparse(x):  # the CSR matrices of FE models
                x = sp.csr_array(x)
                x.sum_duplicates()
                return {"shape": list(x.shape), "indptr": x.indptr.tolist(),
                        "indices": x.indices.tolist(), "data": x.data.tolist()}
            if isinstance(x, dict):
                return {str(k): plain(v) for k, v in x.items()}
            if isinstance(x, (list, tuple)):
                return [plain(v) for v in x]
            if isinstance(x, (np.floating, np.integer)):
                return x.item()
            return x

        return plain({
            "format": _FORMAT,
            "model": self.base,
            "method": self.integrator.to_spec(),
            "newton": self.integrator.newton.to_spec(),
            "adaptive": self.adaptive,
            "dt": self.dt,
            "params": [{"path": p, "values": v}
                       for p, v in zip(self.paths, self.values, strict=True)],
            "transient": self.transient,
            "periods": self.periods,
            "dofs": self.dofs,
            "max_impacts": self.max_impacts,
            "period_load": self.period_load,
            "directions": self.directions,
            # (only when not 1: the hashes of the sweeps from before it are kept)
            **({"samples_per_period": self.samples_per_period}
               if self.samples_per_period != 1 else {}),
        })


def _plan(sweep: Sweep) -> _Plan:
    m = sweep.method
    assert m is not None and sweep.max_impacts is not None and sweep.dofs is not None
    return _Plan(
        base=sweep.model.to_spec(),
        integrator=m,
        dt=float(sweep.dt),
        paths=tuple(p.path for p in sweep.params),
        values=tuple(np.asarray(p.values, dtype=float) for p in sweep.params),
        transient=sweep.transient,
        periods=sweep.periods,
        dofs=tuple(sweep.dofs),
        max_impacts=int(sweep.max_impacts),
        period_load=sweep.period_load,
        directions=sweep.directions,
        samples_per_period=sweep.samples_per_period,
    )


def _chunks(plan: _Plan, continuation: str, chunk_size: int | None) -> tuple[list[_Chunk], int]:
    """The chunks of a sweep (dependencies always have lower indices) and the chunk size."""
    n = plan.n_jobs
    if continuation == "none":
        size = chunk_size or max(1, min(256, math.ceil(n / 20)))
        return [_Chunk(i, tuple(range(a, min(a + size, n))), None, (), ())
                for i, a in enumerate(range(0, n, size))], size
    # chains along the first parameter, one per direction and per point of the others
    shape = plan.shape
    grid = np.arange(plan.n_grid).reshape(shape)
    lines = grid.reshape(shape[0], -1).T  # (other points, first parameter)
    chains: list[list[int]] = []
    for d, direction in enumerate(plan.directions):
        for line in lines:
            jobs = [int(j) + d * plan.n_grid for j in line]
            chains.append(jobs if direction == "up" else jobs[::-1])
    length = shape[0]
    size = chunk_size or max(1, min(256, math.ceil(length / 5)))
    segments = [(level, chain[a:a + size], chain[a - 1] if a else None)
                for chain in chains for level, a in enumerate(range(0, length, size))]
    out: list[_Chunk] = []
    where: dict[int, int] = {}
    for level in range(math.ceil(length / size)):
        batch: list[tuple[list[int], int | None]] = []
        count = 0

        def flush() -> None:
            nonlocal batch, count
            if not batch:
                return
            index = len(out)
            starts = tuple((seg[0], prev) for seg, prev in batch if prev is not None)
            deps = tuple(sorted({where[prev] for _, prev in starts}))
            jobs = tuple(j for seg, _ in batch for j in seg)
            out.append(_Chunk(index, jobs, tuple(tuple(seg) for seg, _ in batch), starts, deps))
            for j in jobs:
                where[j] = index
            batch, count = [], 0

        for lv, seg, prev in segments:
            if lv != level:
                continue
            if count and count + len(seg) > size:
                flush()
            batch.append((seg, prev))
            count += len(seg)
        flush()
    return out, size


#: Keys of a chunk result with one row per job.
_FLOAT_KEYS = ("poincare_displacement", "poincare_velocity", "displacement_max",
               "displacement_min", "displacement_rms", "impact_velocity_max", "impact_velocity",
               "impact_phase", "final_displacement", "final_velocity", "final_time")
_INT_KEYS = ("impact_count", "steps", "newton_iterations", "rejected_steps")


def compute_chunk(plan: _Plan, chunk: _Chunk, threads: int | None = None,
                  deps: Sequence[dict[str, Any]] = ()) -> dict[str, Any]:
    """Runs one chunk in the core (all its points in parallel on ``threads`` threads, default
    all cores) and returns its rows: the arrays of ``_core.sweep`` plus ``jobs`` (the job
    indices) and ``error`` (a str array, empty where the point ran through). ``deps`` are the
    results of the chunks that hold the previous points of its chains. A model error is
    returned as ``{"model_error": message}`` (exceptions of the core do not unpickle on
    another process)."""
    carry: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for r in deps:
        for k, j in enumerate(np.asarray(r["jobs"]).tolist()):
            if not str(r["error"][k]):
                carry[j] = (np.asarray(r["final_displacement"][k]),
                            np.asarray(r["final_velocity"][k]))
    previous = dict(chunk.starts)
    try:
        specs = [plan.job_spec(j, carry.get(previous[j]) if j in previous else None)
                 for j in chunk.jobs]
        position = {j: i for i, j in enumerate(chunk.jobs)}
        chains = None if chunk.chains is None else [[position[j] for j in c]
                                                    for c in chunk.chains]
        raw = _core.sweep(specs, chains, threads)
    except ModelError as e:
        return {"model_error": str(e)}
    out: dict[str, Any] = {k: np.asarray(raw[k]) for k in (*_FLOAT_KEYS, *_INT_KEYS)}
    out["wall_time"] = np.asarray(raw["wall_time"])
    out["jobs"] = np.asarray(chunk.jobs, dtype=np.int64)
    out["error"] = np.asarray([e or "" for e in raw["error"]], dtype=str)
    return out


# --------------------------------------------------------------------------------------------
# Progress and resumable parts
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ChunkEvent:
    """A chunk finished: ``index``, its ``points``, ``done``/``total`` points so far, and
    whether it was ``reused`` from the parts of an earlier, interrupted run."""

    index: int
    points: int
    done: int
    total: int
    reused: bool


class _Progress:
    """One stderr line, rewritten in place (only on a terminal)."""

    def __init__(self, total: int, enabled: bool | None) -> None:
        self.total = total
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.t0 = time.perf_counter()
        self.last = 0.0
        self.done = 0

    def update(self, done: int, force: bool = False) -> None:
        self.done = done
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self.last < 0.2 and done < self.total:
            return
        self.last = now
        elapsed = now - self.t0
        eta = ""
        if 0 < done < self.total:
            eta = f", about {elapsed * (self.total - done) / done:.0f} s left"
        pct = 100.0 * done / max(self.total, 1)
        sys.stderr.write(f"\rsweep: {done}/{self.total} points ({pct:.0f}%) "
                         f"{elapsed:.1f} s{eta}   ")
        sys.stderr.flush()

    def message(self, text: str) -> None:
        if self.enabled:
            sys.stderr.write(f"sweep: {text}\n")
            sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            self.update(self.done, force=True)
            sys.stderr.write("\n")
            sys.stderr.flush()


def _atomic_savez(path: Path, arrays: dict[str, Any]) -> None:
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:  # a handle: np.savez would append ".npz" to a name
            np.savez(f, **arrays)

    atomic_write({path: write})


def _load_part(path: Path) -> dict[str, Any] | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, KeyError, EOFError):
        return None  # a damaged part is simply recomputed


def _part_path(folder: Path, index: int) -> Path:
    return folder / f"chunk-{index:05d}.npz"


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------


def _validate(plan: _Plan) -> None:
    """Refuse bad paths and bad values before anything runs: every value of each parameter
    with the others at their first value goes through the core's model checks."""
    jobs: list[int] = []
    shape = plan.shape
    for axis, n in enumerate(shape):
        for i in range(n):
            index = [0] * len(shape)
            index[axis] = i
            jobs.append(int(np.ravel_multi_index(index, shape)))
    plan.job_spec(0)  # a bad path is refused as such, whatever the values
    specs, labels = [], []
    for j in sorted(set(jobs)):
        try:
            specs.append(plan.job_spec(j))
        except ModelError as e:
            raise ModelError(f"sweep point {_describe(plan, j)}: {e}") from None
        labels.append(_describe(plan, j))
    _core.sweep_check(specs, labels)


def _describe(plan: _Plan, j: int) -> str:
    index = np.unravel_index(j % plan.n_grid, plan.shape)
    parts = [f"{p}={v[i]:g}" for p, v, i in zip(plan.paths, plan.values, index, strict=True)]
    d = plan.directions[j // plan.n_grid]
    return ", ".join(parts) + (f" ({d})" if d else "")


def _run_local(plan: _Plan, chunks: Sequence[_Chunk], todo: Iterable[int],
               results: dict[int, dict[str, Any]], threads: int | None,
               done: Callable[[_Chunk, dict[str, Any]], None]) -> None:
    """Runs the chunks in ``todo`` in this process, two core calls at a time (each on all
    cores; the second keeps the cores busy while the first finishes its last points)."""
    remaining = [chunks[i] for i in sorted(todo)]
    pending: dict[Future[dict[str, Any]], _Chunk] = {}
    with ThreadPoolExecutor(max_workers=2, thread_name_prefix="vibroimpact-sweep") as ex:
        try:
            while remaining or pending:
                ready = [c for c in remaining if all(d in results for d in c.deps)]
                for c in ready[: max(0, 2 - len(pending))]:
                    fut = ex.submit(compute_chunk, plan, c, threads,
                                    [results[d] for d in c.deps])
                    pending[fut] = c
                    remaining.remove(c)
                if not pending:
                    raise RuntimeError("sweep: chunk dependencies cannot be met")
                finished, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in finished:
                    c = pending.pop(fut)
                    r = fut.result()
                    if "model_error" in r:
                        raise ModelError(r["model_error"])
                    results[c.index] = r
                    done(c, r)
        except BaseException:
            # Ctrl-C or an error: stop the chunks still running (their points stop within
            # ~1000 steps and the calls raise KeyboardInterrupt); finished chunks are on disk.
            _core.request_interrupt()
            for fut in pending:
                fut.cancel()
            wait(pending)
            _core.clear_interrupt()
            raise


@contextlib.contextmanager
def _signals_stop_the_chunks(received: list[int]) -> Iterator[None]:
    """On the main thread, Ctrl-C (SIGINT) and SIGTERM are noted in ``received`` and raise
    :class:`KeyboardInterrupt`, which stops the running chunks (SIGTERM would otherwise end
    the process at once, saying nothing of the parts kept)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        received.append(signum)
        raise KeyboardInterrupt(f"signal {signum}")

    previous: dict[int, Any] = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, handler)
    except (ValueError, OSError):  # pragma: no cover - no signals here
        pass
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


def _interrupted_message(signum: int, folder: Path | None, chunks: Sequence[_Chunk],
                         results: dict[int, dict[str, Any]], n_jobs: int) -> str:
    """What an interrupted sweep keeps, on one line."""
    name = signal.Signals(signum).name
    if folder is None:
        return (f"sweep stopped by {name}: no points kept (without an output file, finished "
                "chunks are not kept)")
    kept = [c for c in chunks if c.index in results and _part_path(folder, c.index).exists()]
    points = sum(len(c.jobs) for c in kept)
    return (f"sweep stopped by {name}: {points} of {n_jobs} points ({len(kept)} of "
            f"{len(chunks)} chunks) are kept in {folder.parent}/; the same command (the same "
            "sweep and output) resumes from them")


def run_sweep(
    sweep: Sweep,
    *,
    output: str | os.PathLike[str] | None = None,
    client: Any = None,
    threads: int | None = None,
    progress: bool | None = None,
    resume: bool = True,
    on_chunk: Callable[[ChunkEvent], None] | None = None,
) -> xr.Dataset:
    """Run ``sweep`` and return its Dataset (also written to ``output``, ``.nc`` or ``.h5``,
    atomically, if given).

    - ``client``: a ``dask.distributed.Client``: chunks become tasks on its workers (see
      :func:`vibroimpact.sweeps.distributed.dask_client`); None runs in this process.
    - ``threads``: core threads per chunk (default all cores of the machine running it).
    - ``progress``: a progress line on stderr (default: when stderr is a terminal).
    - ``resume``: with ``output``, keep finished chunks in ``OUTPUT.parts/`` and reuse those of
      an interrupted run of the same sweep; the parts are removed once the file is written.
    - ``on_chunk``: called with a :class:`ChunkEvent` as each chunk finishes or is reused.

    ``Ctrl-C`` or SIGTERM (on the main thread) stops the running chunks and raises
    :class:`~vibroimpact.Interrupted` saying how many points are kept in ``OUTPUT.parts/``
    (``signum``: the signal); the same call then resumes from them.
    """
    started = time.perf_counter()
    require(isinstance(sweep, Sweep), "sweep", type(sweep).__name__, "a vibroimpact Sweep")
    require(threads is None or (isinstance(threads, int) and threads >= 1), "--threads",
            threads, "an integer >= 1")
    out_path = None if output is None else _check_output(output)
    plan = _plan(sweep)
    _validate(plan)
    chunks, size = _chunks(plan, sweep.continuation, sweep.chunk_size)
    definition = plan.definition()
    definition["chunk_size"] = size
    digest = hashlib.sha256(json.dumps(definition, sort_keys=True).encode()).hexdigest()[:20]

    folder = None
    results: dict[int, dict[str, Any]] = {}
    if out_path is not None and resume:
        folder = out_path.with_name(out_path.name + ".parts") / digest
        folder.mkdir(parents=True, exist_ok=True)
        for c in chunks:
            p = _part_path(folder, c.index)
            if p.exists():
                r = _load_part(p)
                if r is not None and np.array_equal(r.get("jobs", []), c.jobs):
                    results[c.index] = r
    bar = _Progress(plan.n_jobs, progress)
    done_points = 0

    def finished(c: _Chunk, r: dict[str, Any], reused: bool = False) -> None:
        nonlocal done_points
        if folder is not None and not reused:
            _atomic_savez(_part_path(folder, c.index), r)
        done_points += len(c.jobs)
        bar.update(done_points)
        if on_chunk is not None:
            on_chunk(ChunkEvent(c.index, len(c.jobs), done_points, plan.n_jobs, reused))

    if results:
        bar.message(f"resuming: {len(results)} of {len(chunks)} chunks already done "
                    f"({folder})")
    for i in sorted(results):
        finished(chunks[i], results[i], reused=True)
    todo = [c.index for c in chunks if c.index not in results]
    _core.clear_interrupt()  # a stale request would stop every point
    received: list[int] = []
    try:
        with _signals_stop_the_chunks(received):
            if client is None:
                _run_local(plan, chunks, todo, results, threads, finished)
            else:
                from vibroimpact.sweeps.distributed import run_on_dask

                run_on_dask(client, plan, chunks, todo, results, threads, finished, digest)
    except KeyboardInterrupt as e:
        # a signal (the one noted here, or one held while a part was written); any other
        # KeyboardInterrupt (raised by on_chunk, say) goes on as it is
        signum = received[0] if received else getattr(e, "signum", None)
        if signum is None:
            raise
        raise Interrupted(_interrupted_message(signum, folder, chunks, results, plan.n_jobs),
                          signum=signum) from None
    finally:
        bar.close()
    ds = _dataset(sweep, plan, chunks, results, digest)
    ds.attrs["wall_time_s"] = time.perf_counter() - started
    ds.attrs["chunks_computed"] = len(todo)
    ds.attrs["chunks_reused"] = len(chunks) - len(todo)
    if out_path is not None:
        save_sweep(ds, out_path)
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
            try:
                folder.parent.rmdir()
            except OSError:
                pass  # other sweeps' parts remain
    return ds


# --------------------------------------------------------------------------------------------
# The Dataset
# --------------------------------------------------------------------------------------------

#: Data variables: (dims after the grid's, unit, description). The unit of those on ``dof``
#: and ``model_dof`` is that of translations; see :data:`DOF_QUANTITIES`.
VARIABLES: dict[str, tuple[tuple[str, ...], str, str]] = {
    "poincare_displacement": (("sample", "dof"), "m",
                              "displacement at t = (transient + sample / samples_per_period) "
                              "* forcing_period"),
    "poincare_velocity": (("sample", "dof"), "m/s",
                          "velocity at t = (transient + sample / samples_per_period) * "
                          "forcing_period"),
    "displacement_max": (("dof",), "m", "largest displacement after the transient"),
    "displacement_min": (("dof",), "m", "smallest displacement after the transient"),
    "displacement_rms": (("dof",), "m", "RMS displacement after the transient"),
    "impact_count": (("gap",), "1", "impacts (contacts begun) after the transient"),
    "impact_velocity_max": (("gap",), "m/s", "largest approach speed after the transient"),
    "impact_velocity": (("gap", "impact"), "m/s",
                        "approach speed of the first impacts after the transient"),
    "impact_phase": (("gap", "impact"), "1",
                     "forcing phase of those impacts, fraction of the period"),
    "final_displacement": (("model_dof",), "m", "displacement at the end of the run"),
    "final_velocity": (("model_dof",), "m/s", "velocity at the end of the run"),
    "steps": ((), "1", "accepted steps"),
    "newton_iterations": ((), "1", "Newton iterations"),
    "rejected_steps": ((), "1", "rejected step attempts"),
}

#: The :data:`VARIABLES` on ``dof`` or ``model_dof`` → their quantity in
#: :data:`vibroimpact.result.DOF_VARIABLES`: their ``units`` follow the DOFs' units (the
#: coordinates ``dof_unit`` and ``model_dof_unit``) as in a single run's Dataset
#: (:func:`vibroimpact.result.dof_variable_units`): ``"rad"`` for rotations, ``"m or rad per
#: dof_unit"`` for a mixed set.
DOF_QUANTITIES: dict[str, str] = {
    "poincare_displacement": "displacement", "poincare_velocity": "velocity",
    "displacement_max": "displacement", "displacement_min": "displacement",
    "displacement_rms": "displacement",
    "final_displacement": "displacement", "final_velocity": "velocity",
}


def _dataset(sweep: Sweep, plan: _Plan, chunks: Sequence[_Chunk],
             results: dict[int, dict[str, Any]], digest: str) -> xr.Dataset:
    import xarray as xr

    n = plan.n_jobs
    first = results[chunks[0].index]
    rows: dict[str, np.ndarray] = {}
    for key in VARIABLES:
        a = np.asarray(first[key])
        rows[key] = np.empty((n, *a.shape[1:]), dtype=a.dtype)
    errors = np.full(n, "", dtype=object)
    for c in chunks:
        r = results[c.index]
        jobs = np.asarray(r["jobs"])
        for key in VARIABLES:
            rows[key][jobs] = r[key]
        errors[jobs] = np.asarray(r["error"], dtype=object)
    grid_dims = tuple(plan.paths)
    shape = plan.shape
    lead: tuple[str, ...] = ()
    lead_shape: tuple[int, ...] = ()
    if sweep.continuation == "both":
        lead, lead_shape = ("direction",), (2,)
    dims = (*lead, *grid_dims)
    full_shape = (*lead_shape, *shape)
    model_units = sweep.model.structure.dof_units
    units = {"dof": [model_units[d] for d in plan.dofs], "model_dof": list(model_units)}
    data_vars: dict[str, Any] = {}
    for key, (extra, unit, text) in VARIABLES.items():
        if key in DOF_QUANTITIES:
            unit = dof_variable_units(DOF_QUANTITIES[key], units[extra[-1]],
                                      f"{extra[-1]}_unit")[1]
        a = rows[key].reshape(*full_shape, *rows[key].shape[1:])
        data_vars[key] = ((*dims, *extra), a, {"units": unit, "long_name": text})
    periods = np.array([plan.period(plan.point_model(j)) for j in range(plan.n_grid)])
    data_vars["forcing_period"] = (grid_dims, periods.reshape(shape),
                                   {"units": "s", "long_name": "sampling (forcing) period"})
    failed = np.array([bool(e) for e in errors]).reshape(full_shape)
    data_vars["failed"] = (dims, failed, {"long_name": "the run stopped early (see attrs "
                                                       "errors)"})
    coords: dict[str, Any] = {}
    for p in sweep.params:
        coords[p.path] = (p.path, np.asarray(p.values), {"units": p.units,
                                                          "long_name": p.path})
    if lead:
        coords["direction"] = ("direction", np.array(["up", "down"]))
    n_samples = rows["poincare_displacement"].shape[1]
    coords["sample"] = ("sample", np.arange(1, n_samples + 1))
    coords["dof"] = ("dof", np.asarray(plan.dofs, dtype=np.int64))
    n_gaps = rows["impact_count"].shape[1]
    coords["gap"] = ("gap", np.arange(n_gaps))
    coords["impact"] = ("impact", np.arange(rows["impact_velocity"].shape[2]))
    coords["model_dof"] = ("model_dof", np.arange(rows["final_displacement"].shape[1]))
    for dim, per_dof in units.items():
        coords[f"{dim}_unit"] = (dim, np.array(per_dof, dtype=str),
                                 {"long_name": DOF_UNIT_DESCRIPTION})
    listed = []
    for j in np.flatnonzero(errors != ""):
        listed.append({"point": _describe(plan, int(j)), "message": str(errors[j])})
        if len(listed) >= 50:
            break
    from vibroimpact import __version__

    attrs = {
        "kind": "vibroimpact-sweep",
        "vibroimpact_version": __version__,
        "params": json.dumps([p.path for p in sweep.params]),
        "transient_periods": plan.transient,
        "sampled_periods": plan.periods,
        "samples_per_period": plan.samples_per_period,
        "continuation": sweep.continuation,
        "continuation_axis": plan.paths[0] if sweep.continuation != "none" else "",
        "dt": plan.dt,
        "method": json.dumps(plan.integrator.to_spec()),
        "adaptive": json.dumps(plan.adaptive),
        "period_load": -1 if plan.period_load is None else plan.period_load,
        "definition_hash": digest,
        "failed_points": int(failed.sum()),
        "errors": json.dumps(listed),
    }
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def _check_output(path: str | os.PathLike[str]) -> Path:
    p = Path(path)
    if p.suffix.lower() not in SUFFIXES:
        raise ModelError(f"-o: {str(path)!r} is not valid; expected a file name ending in "
                         + ", ".join(SUFFIXES))
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ModelError(f"-o: {str(path)!r} is not valid; expected a file in an existing "
                         "folder")
    return p


def save_sweep(ds: xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Write a sweep Dataset to NetCDF-4 (``.nc``/``.h5``) atomically: a temporary file in the
    same folder, then renamed over ``path``. Booleans are stored as int8."""
    p = _check_output(path)
    out = ds.copy()
    encoding: dict[str, dict[str, Any]] = {}
    for name, var in out.variables.items():
        if var.dtype.kind == "b":
            out[name] = var.astype(np.int8)
            out[name].attrs["flag"] = "bool"
        elif var.dtype.kind in "f":
            encoding[str(name)] = {"_FillValue": None}
    try:
        atomic_write({p: lambda tmp: out.to_netcdf(tmp, engine=netcdf_engine(), format="NETCDF4",
                                                   encoding=encoding)})
    except OSError as e:
        raise ModelError(f"-o: cannot write {str(path)!r}: {e.strerror or e}") from None
    return p


def load_sweep(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read a Dataset written by :func:`save_sweep` (or ``vibroimpact sweep -o``)."""
    import xarray as xr

    p = Path(path)
    if not p.is_file():
        raise ModelError(f"RESULT: {str(path)!r} is not valid; expected an existing sweep file")
    try:
        ds = xr.load_dataset(p, engine=netcdf_engine())
    except (OSError, ValueError) as e:
        raise ModelError(f"RESULT: cannot read {str(path)!r} as NetCDF ({e}); expected a file "
                         "written by vibroimpact sweep") from None
    if ds.attrs.get("kind") != "vibroimpact-sweep":
        raise ModelError(f"RESULT: {str(path)!r} is not a sweep; expected a file written by "
                         "vibroimpact sweep")
    for name in list(ds.variables):
        var = ds[name].variable
        if var.attrs.get("flag") == "bool":
            ds[name] = xr.Variable(var.dims, var.values.astype(bool),
                                   {k: v for k, v in var.attrs.items() if k != "flag"})
    return ds

