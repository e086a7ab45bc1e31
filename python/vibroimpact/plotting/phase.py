"""Phase portraits: velocity against displacement of each recorded DOF."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from vibroimpact.plotting._data import select, time_mask
from vibroimpact.plotting.time_history import axis_label, line_label

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes


def phase_portrait(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    dofs: Sequence[int] | int | None = None,
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """Velocity against displacement, one curve per selected DOF."""
    mask = time_mask(ds, t_min, t_max)
    chosen = select(ds, "dof", dofs)
    x, v = ds["displacement"].values, ds["velocity"].values
    for pos, index in chosen:
        ax.plot(x[mask, pos], v[mask, pos], label=line_label(label, "dof", index,
                                                             len(chosen) > 1), **style)
    positions = [pos for pos, _ in chosen]
    ax.set_xlabel(axis_label(ds, "displacement", positions))
    ax.set_ylabel(axis_label(ds, "velocity", positions))
