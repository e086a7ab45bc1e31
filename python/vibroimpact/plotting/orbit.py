"""Rotor orbits: y against x at a pair of DOFs, with the stator's clearance circle."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from vibroimpact.errors import ModelError, require
from vibroimpact.plotting._data import select, time_mask

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes


def orbit(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    dofs: Sequence[int] | None = None,
    node: int | None = None,
    clearance: float | None = None,
    center: Sequence[float] = (0.0, 0.0),
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """The orbit ``y(t)`` against ``x(t)`` at the recorded DOFs ``dofs = [ix, iy]`` (default:
    the first two, a Jeffcott rotor's), or at the x and y of ``node`` in the result's DOF map
    (:attr:`vibroimpact.Result.dof_map`), equal axes; with ``clearance`` (m) the stator's
    circle of that radius about ``center = (x_s, y_s)`` (m), dashed."""
    if node is not None:
        from vibroimpact.io.results_file import node_dofs

        require(dofs is None, "--node", node, "either --node N or --dof IX --dof IY, not both")
        dofs = node_dofs(ds, node)
    if dofs is None:
        chosen = select(ds, "dof", None)[:2]
    else:
        require(len(dofs) == 2, "--dof", list(dofs), "two DOFs: --dof IX --dof IY")
        chosen = select(ds, "dof", dofs)
    if len(chosen) != 2:
        raise ModelError(f"--dof: {len(chosen)} recorded DOFs; expected two (x and y: --dof IX "
                         "--dof IY)")
    (px, ix), (py, iy) = chosen
    from vibroimpact.io.results_file import dof_units

    units = dof_units(ds)
    for p, i in ((px, ix), (py, iy)):
        if units[p] != "m":
            raise ModelError(f"--dof: {i} is a DOF in {units[p]}; expected translations in m "
                             "(the x and y of one node)")
    mask = time_mask(ds, t_min, t_max)
    x = ds["displacement"].values
    ax.plot(x[mask, px], x[mask, py], label=label, **style)
    if clearance is not None:
        require(bool(np.isfinite(clearance)) and clearance > 0, "--clearance", clearance,
                "a clearance > 0 in m")
        require(len(center) == 2 and bool(np.all(np.isfinite(center))), "--center",
                list(center), "two finite numbers X Y in m")
        angle = np.linspace(0.0, 2 * np.pi, 361)
        ax.plot(center[0] + clearance * np.cos(angle), center[1] + clearance * np.sin(angle),
                "k--", lw=0.8, label=f"clearance {clearance:g} m")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"x: displacement of DOF {ix} [m]")
    ax.set_ylabel(f"y: displacement of DOF {iy} [m]")
