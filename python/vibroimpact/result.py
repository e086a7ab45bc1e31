"""What a run returns (docs/conventions.md): time histories, the impact table, the energy account
and solver statistics, as numpy arrays with pandas/xarray views."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from vibroimpact.errors import ModelError

if TYPE_CHECKING:
    import os
    from pathlib import Path

    import pandas as pd
    import xarray as xr
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from vibroimpact.integrators import Integrator
    from vibroimpact.model import Model

__all__ = ["EnergyAccount", "ImpactTable", "Result", "SolverStats"]

Array = NDArray[np.float64]
_T = TypeVar("_T")

#: Units and descriptions of the impact-table columns.
IMPACT_COLUMNS: dict[str, tuple[str, str]] = {
    "gap": ("", "gap index"),
    "side": ("", "wall hit: positive, negative or radial"),
    "t_start": ("s", "instant the gap closed"),
    "t_end": ("s", "instant the gap opened (NaN: still closed at the end)"),
    "v_in": ("m/s", "approach speed at closing"),
    "v_out": ("m/s", "separation speed at opening"),
    "restitution_effective": ("", "v_out / v_in"),
    "delta_max": ("m", "largest penetration"),
    "force_max": ("N", "largest contact force"),
    "friction_max": ("N", "largest friction force of a radial gap's contact (0: a 1-D gap)"),
    "impulse": ("N s", "integral of the contact force"),
}


#: Energy-account terms (``energy_<term>`` variables), J.
ENERGY_TERMS = ("kinetic", "strain", "contact_potential", "external_work",
                "damping_dissipated", "contact_dissipated")

#: The time-history variables of :meth:`Result.to_xarray` (and of a result file): name →
#: (dims, units, description, key of the core's output: a column, or ``energy.<term>``).
TIME_VARIABLES: dict[str, tuple[tuple[str, ...], str, str, str]] = {
    "displacement": (("time", "dof"), "m", "displacement", "displacement"),
    "velocity": (("time", "dof"), "m/s", "velocity", "velocity"),
    "acceleration": (("time", "dof"), "m/s^2", "acceleration", "acceleration"),
    "penetration": (("time", "gap"), "m", "gap penetration (<0: open)", "gap_penetration"),
    "contact_force": (("time", "gap"), "N", "contact force", "gap_force"),
    **{f"energy_{t}": (("time",), "J", t, f"energy.{t}") for t in ENERGY_TERMS},
}


#: ``long_name`` of the ``dof_unit`` coordinate.
DOF_UNIT_DESCRIPTION = "displacement unit of the DOF (velocity: per s, acceleration: per s^2)"

#: The time-history variables on ``(time, dof)``: name → (column prefix of tables and CSV
#: files, the time derivative in the unit: displacement ``u``, velocity ``u/s``, acceleration
#: ``u/s^2`` for a DOF of unit ``u``).
DOF_VARIABLES: dict[str, tuple[str, str]] = {
    "displacement": ("x", ""), "velocity": ("v", "/s"), "acceleration": ("a", "/s^2"),
}


def dof_variable_units(name: str, dof_units: Sequence[str], coord: str = "dof_unit"
                       ) -> tuple[list[str], str]:
    """The units of the :data:`DOF_VARIABLES` ``name`` per DOF of ``dof_units`` (``"rad"``
    → ``"rad/s"`` for the velocity) and the ``units`` attribute of the variable: that unit if
    every DOF has it, else ``"m or rad per dof_unit"`` (a mixed set: the coordinate ``coord``
    gives each DOF's displacement unit). Also the sweeps' variables on ``dof``/``model_dof``."""
    per_time = DOF_VARIABLES[name][1]
    per_dof = [f"{u}{per_time}" for u in dof_units]
    if not per_dof:  # no DOF recorded
        return per_dof, TIME_VARIABLES[name][1]
    listed = unit_set(dof_units, per_time)
    return per_dof, listed if len(set(dof_units)) == 1 else f"{listed} per {coord}"


def unit_set(dof_units: Sequence[str], per_time: str = "") -> str:
    """The distinct units among ``dof_units`` with ``per_time`` appended, in the order of
    :data:`vibroimpact.model.DOF_UNITS`, joined by ``" or "`` (``"m or rad"``)."""
    from vibroimpact.model import DOF_UNITS

    order = {u: i for i, u in enumerate(DOF_UNITS)}
    distinct = sorted(set(dof_units), key=lambda u: (order.get(u, len(order)), u))
    return " or ".join(f"{u}{per_time}" for u in distinct)


def time_columns(raw: dict[str, Any]) -> dict[str, Array]:
    """The :data:`TIME_VARIABLES` (and ``time``) of the core's output or of a block of rows
    it streamed (``on_rows`` of :func:`vibroimpact.simulate`)."""
    out = {"time": np.asarray(raw["time"])}
    for name, (*_, key) in TIME_VARIABLES.items():
        head, _, term = key.partition(".")
        out[name] = np.asarray(raw[head][term] if term else raw[head])
    return out


def _json_number(x: float) -> float | None:
    return None if math.isnan(x) else float(x)


def _assembled(cls: type[_T], values: dict[str, Any]) -> _T:
    """The frozen dataclass ``cls`` holding ``values`` (one per field, already checked: the
    core's output), set in one step: its ``__init__`` sets each field by
    ``object.__setattr__``, ~0.3 µs a field, most of the cost of a short run's result."""
    obj = object.__new__(cls)
    obj.__dict__.update(values)
    return obj


#: ``side`` of an impact, indexed by the core's side column (0: negative wall, 1: positive,
#: 2: a radial gap's).
_SIDES = np.array(["negative", "positive", "radial"])


@dataclass(frozen=True)
class ImpactTable:
    """One row per contact of one wall (columns: :data:`IMPACT_COLUMNS`)."""

    gap: NDArray[np.int64]
    side: NDArray[np.str_]
    t_start: Array
    t_end: Array
    v_in: Array
    v_out: Array
    restitution_effective: Array
    delta_max: Array
    force_max: Array
    friction_max: Array
    impulse: Array

    @classmethod
    def from_core(cls, raw: dict[str, Any]) -> ImpactTable:
        """From the core's columns: the fields, with ``side`` 0 (negative), 1 (positive) or 2
        (radial)."""
        return _assembled(cls, {**raw, "side": _SIDES[raw["side"]]})

    def __len__(self) -> int:
        return len(self.t_start)

    def to_records(self) -> list[dict[str, Any]]:
        """JSON-ready rows (``None`` where a contact was still closed at the end)."""
        rows = []
        for i in range(len(self)):
            row: dict[str, Any] = {"gap": int(self.gap[i]), "side": str(self.side[i])}
            for f in fields(self):
                if f.name not in row:
                    row[f.name] = _json_number(float(getattr(self, f.name)[i]))
            rows.append(row)
        return rows

    def to_dataframe(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame({f.name: getattr(self, f.name) for f in fields(self)})


@dataclass(frozen=True)
class EnergyAccount:
    """Energies at the recorded instants, J. ``balance = E + D − E₀ − W_ext`` is zero up to the
    time discretisation; ``balance_error`` is its largest magnitude relative to the largest
    energy that entered the system."""

    kinetic: Array
    strain: Array
    contact_potential: Array
    external_work: Array
    damping_dissipated: Array
    contact_dissipated: Array
    balance_error: float

    @property
    def total(self) -> Array:
        """Kinetic + strain + contact potential, J."""
        return self.kinetic + self.strain + self.contact_potential

    @property
    def balance(self) -> Array:
        return (
            self.total
            + self.damping_dissipated
            + self.contact_dissipated
            - self.total[0]
            - self.external_work
        )


@dataclass(frozen=True)
class SolverStats:
    steps: int
    newton_iterations: int
    rejected_steps: int
    step_cuts: int
    wall_time_s: float
    #: Which step ran: ``"fixed-size N=1"`` ... ``"N=4"`` (the Newmark family's step compiled
    #: for a model of that many DOFs) or ``"general"``.
    step_path: str = "general"


@dataclass(frozen=True)
class Result:
    """A run: time histories of the recorded DOFs (rows: time), per-gap penetration (m,
    negative = open) and contact force (N), the impact table, the energy account and solver
    statistics. ``complete`` is False (and ``message`` says why) if the solver stopped early.
    ``dof_units``: the displacement unit of each recorded DOF (``"m"``, ``"rad"``, ...: the
    structure's :attr:`~vibroimpact.Structure.dof_units`; default ``"m"`` for all)."""

    time: Array
    dofs: NDArray[np.int64]
    displacement: Array
    velocity: Array
    acceleration: Array
    gap_penetration: Array
    gap_force: Array
    max_abs_displacement: Array
    impacts: ImpactTable
    energy: EnergyAccount
    stats: SolverStats
    dt: float
    t_end: float
    complete: bool
    message: str
    model: Model | None = None
    method: Integrator | None = None
    dof_units: tuple[str, ...] = ()
    #: The node and direction of each of the model's DOFs (a :class:`vibroimpact.fe.DofMap`:
    #: a beam's, a matrices file's, a Jeffcott rotor's node 0 x and y), kept in the result
    #: file so that ``plot --kind orbit --node N`` finds a node's x and y; None: unknown. The
    #: model's structure's (:attr:`vibroimpact.Structure.dof_map`), or a model file's (its DOFs
    #: with the massless ones recovered).
    dof_map: Any = None

    def __post_init__(self) -> None:
        units = tuple(self.dof_units) or ("m",) * len(self.dofs)
        if len(units) != len(self.dofs):
            raise ModelError(f"dof_units: {list(units)} is not valid; expected "
                             f"{len(self.dofs)} units (one per recorded DOF)")
        object.__setattr__(self, "dof_units", units)

    @classmethod
    def from_core(
        cls,
        raw: dict[str, Any],
        *,
        model: Model | None,
        method: Integrator | None,
        t_end: float,
    ) -> Result:
        """The result of the core's output ``raw`` (``_core.Running.finish``) of a run of
        ``model`` by ``method`` to ``t_end``: its fields set as :func:`_assembled` sets them,
        with what ``__post_init__`` would (``dof_units``)."""
        error = raw["error"]
        dofs = raw["dofs"]
        units = ("m",) * len(dofs) if model is None else tuple(
            [model.structure.dof_units[d] for d in dofs.tolist()])
        return _assembled(cls, {
            "time": raw["time"],
            "dofs": dofs,
            "displacement": raw["displacement"],
            "velocity": raw["velocity"],
            "acceleration": raw["acceleration"],
            "gap_penetration": raw["gap_penetration"],
            "gap_force": raw["gap_force"],
            "max_abs_displacement": raw["max_abs_displacement"],
            "impacts": ImpactTable.from_core(raw["impacts"]),
            "energy": _assembled(EnergyAccount, {
                **raw["energy"], "balance_error": raw["energy_balance_error"]}),
            "stats": _assembled(SolverStats, raw["stats"]),
            "dt": raw["dt"],
            "t_end": t_end,
            "complete": error is None,
            "message": "completed" if error is None else str(error),
            "model": model,
            "method": method,
            "dof_units": units,
            "dof_map": None if model is None else model.structure.dof_map,
        })

    def summary(self) -> dict[str, Any]:
        """The JSON summary printed by ``vibroimpact run --json``."""
        return {
            "complete": self.complete,
            "message": self.message,
            "dofs": [int(d) for d in self.dofs],
            "dof_units": list(self.dof_units),
            "max_abs_displacement": [float(x) for x in self.max_abs_displacement],
            "impacts": self.impacts.to_records(),
            "steps": self.stats.steps,
            "rejected_steps": self.stats.rejected_steps,
            "step_cuts": self.stats.step_cuts,
            "newton_iterations": self.stats.newton_iterations,
            "wall_time_s": self.stats.wall_time_s,
            "step_path": self.stats.step_path,
            "energy_balance_error": self.energy.balance_error,
            "dt": self.dt,
            "t_end": self.t_end,
        }

    def to_dataframe(self) -> pd.DataFrame:
        """Time histories as a DataFrame indexed by ``time [s]``; column names carry units."""
        import pandas as pd

        cols: dict[str, Array] = {}
        units = {name: dof_variable_units(name, self.dof_units)[0] for name in DOF_VARIABLES}
        for j, d in enumerate(self.dofs):
            for name, (prefix, _) in DOF_VARIABLES.items():
                cols[f"{prefix}{d} [{units[name][j]}]"] = getattr(self, name)[:, j]
        for g in range(self.gap_force.shape[1]):
            cols[f"gap{g} penetration [m]"] = self.gap_penetration[:, g]
            cols[f"gap{g} force [N]"] = self.gap_force[:, g]
        for name in ENERGY_TERMS:
            cols[f"energy {name} [J]"] = getattr(self.energy, name)
        return pd.DataFrame(cols, index=pd.Index(self.time, name="time [s]"))

    def to_xarray(self) -> xr.Dataset:
        """An ``xarray.Dataset`` with dims ``time``, ``dof``, ``gap`` and ``impact``; units and
        descriptions as attributes. The coordinate ``dof_unit`` (on ``dof``) is each DOF's
        displacement unit (``"m"``, ``"rad"``); the ``units`` of ``displacement``,
        ``velocity`` and ``acceleration`` are the common one, or for a mixed set e.g.
        ``"m or rad per dof_unit"`` (:func:`dof_variable_units`)."""
        import xarray as xr

        def var(dims: tuple[str, ...], data: Any, units: str, desc: str) -> xr.Variable:
            return xr.Variable(dims, data, attrs={"units": units, "long_name": desc})

        columns = {
            "displacement": self.displacement, "velocity": self.velocity,
            "acceleration": self.acceleration, "penetration": self.gap_penetration,
            "contact_force": self.gap_force,
            **{f"energy_{t}": getattr(self.energy, t) for t in ENERGY_TERMS},
        }
        data = {name: var(dims, columns[name], units, desc)
                for name, (dims, units, desc, _) in TIME_VARIABLES.items()}
        for name in DOF_VARIABLES:
            data[name].attrs["units"] = dof_variable_units(name, self.dof_units)[1]
        imp = self.impacts
        for name, (units, desc) in IMPACT_COLUMNS.items():
            data[f"impact_{name}"] = var(("impact",), getattr(imp, name), units, desc)
        ds = xr.Dataset(
            data,
            coords={
                "time": xr.Variable(("time",), self.time, {"units": "s"}),
                "dof": self.dofs,
                "dof_unit": xr.Variable(("dof",), np.array(self.dof_units, dtype=str),
                                        {"long_name": DOF_UNIT_DESCRIPTION}),
                "gap": np.arange(self.gap_force.shape[1]),
            },
        )
        ds.attrs.update(
            complete=int(self.complete),
            message=self.message,
            dt=self.dt,
            t_end=self.t_end,
            method=repr(self.method),
            steps=self.stats.steps,
            newton_iterations=self.stats.newton_iterations,
            energy_balance_error=self.energy.balance_error,
        )
        from vibroimpact.io.results_file import run_metadata

        attrs, variables = run_metadata(self)  # model, integrator, version: how it was made
        ds.attrs.update(attrs)
        for name, (dims, values, var_attrs) in variables.items():
            ds[name] = xr.Variable(dims, values, attrs=var_attrs)
        return ds

    def save(self, path: str | os.PathLike[str]) -> list[Path]:
        """Write the result atomically to ``path``: ``.nc``/``.h5`` (NetCDF-4) or ``.csv``
        (plus ``_impacts.csv``, ``_energy.csv``, ``_meta.json``); see
        :mod:`vibroimpact.io.results_file`. Returns the files written."""
        from vibroimpact.io.results_file import save

        return save(self, path)

    def plot(
        self,
        kind: str = "displacement",
        *,
        ax: Axes | None = None,
        path: str | os.PathLike[str] | None = None,
        **options: Any,
    ) -> Figure:
        """Draw one of :data:`vibroimpact.plotting.KINDS` (``"displacement"``,
        ``"contact-force"``, ``"force-indentation"``, ``"phase"``, ``"energy"``,
        ``"impact-map"``, ``"spectrum"``, ...) into ``ax`` or a new figure, and save it to
        ``path`` (PNG/SVG/PDF) if given; see :func:`vibroimpact.plotting.plot`."""
        from vibroimpact.plotting import plot

        return plot(self, kind, ax=ax, path=path, **options)
