"""Time histories: displacement, velocity and acceleration of the recorded DOFs, contact
force and penetration of the gaps."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from vibroimpact.plotting._data import select, time_mask

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes

#: Variable, y-axis label, and the dimension it runs over, per time-history kind.
TIME_HISTORIES = {
    "displacement": ("displacement", "displacement [m]", "dof"),
    "velocity": ("velocity", "velocity [m/s]", "dof"),
    "acceleration": ("acceleration", "acceleration [m/s²]", "dof"),
    "contact-force": ("contact_force", "contact force [N]", "gap"),
    "penetration": ("penetration", "penetration δ [m] (< 0: open)", "gap"),
}


#: The time derivative in the unit of a DOF variable, in a plot's notation.
PER_TIME = {"displacement": "", "velocity": "/s", "acceleration": "/s²"}


def axis_label(ds: xr.Dataset, kind: str, positions: Sequence[int]) -> str:
    """The axis label of a :data:`TIME_HISTORIES` kind: for the DOF variables the unit of
    the DOFs at ``positions`` (``dof_unit``: ``[rad]`` for rotations; ``[m or rad]`` for a
    mixed selection), else the fixed label."""
    from vibroimpact.io.results_file import dof_units
    from vibroimpact.result import unit_set

    var, ylabel, dim = TIME_HISTORIES[kind]
    if dim != "dof" or not positions:
        return ylabel
    units = dof_units(ds)
    return f"{ylabel.split(' [')[0]} [{unit_set([units[p] for p in positions], PER_TIME[var])}]"


def _name(dim: str, index: int) -> str:
    return f"x{index}" if dim == "dof" else f"gap {index}"


def line_label(label: str | None, dim: str, index: int, many: bool) -> str | None:
    """A legend entry: the source's label, the DOF/gap, or both."""
    if label is None:
        return _name(dim, index) if many else None
    return f"{label}, {_name(dim, index)}" if many else label


def time_history(
    ds: xr.Dataset,
    ax: Axes,
    kind: str,
    *,
    label: str | None = None,
    dofs: Sequence[int] | int | None = None,
    gaps: Sequence[int] | int | None = None,
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """One line per selected DOF (displacement, velocity, acceleration) or gap (contact
    force, penetration) against time."""
    var, _, dim = TIME_HISTORIES[kind]
    mask = time_mask(ds, t_min, t_max)
    t = ds["time"].values[mask]
    chosen = select(ds, dim, dofs if dim == "dof" else gaps)
    values = ds[var].values
    for pos, index in chosen:
        ax.plot(t, values[mask, pos], label=line_label(label, dim, index, len(chosen) > 1),
                **style)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(axis_label(ds, kind, [pos for pos, _ in chosen]))
