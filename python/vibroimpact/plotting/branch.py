"""Plots of a continued branch (:meth:`vibroimpact.continuation.Branch.to_dataset`, the
``.nc`` file of ``vibroimpact continue -o``): the branch against its parameter (stable parts
solid, unstable dashed, special points marked and named), over a sweep's bifurcation diagram
when one is given, and its Floquet multipliers in the complex plane with the unit circle."""

from __future__ import annotations

import json
import os
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vibroimpact.errors import ModelError

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["BRANCH_KINDS", "BRANCH_QUANTITIES", "branch_dataset", "branch_diagram",
           "branch_values", "cli_plot", "multiplier_plane", "plot_branch"]

#: Plot kinds of branch files: name -> description.
BRANCH_KINDS = {
    "branch": "continue: the branch against its parameter (stable solid, unstable dashed, "
              "special points named; --sweep SWEEP.nc under it)",
    "multipliers": "continue: Floquet multipliers in the complex plane, coloured by the "
                   "parameter, with the unit circle",
}

#: What ``--kind branch`` draws against the parameter: name -> (axis text, unit; None: the
#: DOF's displacement unit). Each has the sweep's counterpart drawn under it with ``--sweep``.
BRANCH_QUANTITIES = {
    "amplitude": ("largest |displacement| over the orbit", None),
    "displacement": ("displacement at the section (t = k T)", None),
    "impact-velocity": ("largest approach speed at impact", "m/s"),
}

#: Marker of each special point type.
_MARKERS = {"fold": "o", "period-doubling": "s", "neimark-sacker": "D", "grazing": "^",
            "branch-point": "X"}


def branch_dataset(source: xr.Dataset | str | os.PathLike[str]) -> xr.Dataset:
    """The Dataset of a branch (a Dataset or a file written by ``vibroimpact continue -o``);
    :class:`ModelError` for anything else."""
    from vibroimpact.continuation import BRANCH_KIND
    from vibroimpact.io.results_file import load

    ds = load(source) if isinstance(source, (str, os.PathLike)) else source
    if ds.attrs.get("kind") != BRANCH_KIND:
        name = f"{str(source)!r}" if isinstance(source, (str, os.PathLike)) else "the Dataset"
        raise ModelError(f"BRANCH: {name} is not valid; expected a branch written by "
                         "vibroimpact continue -o")
    return ds


def _dof(ds: xr.Dataset, dof: int | None) -> int:
    n = ds.sizes["dof"]
    d = 0 if dof is None else int(dof)
    if not 0 <= d < n:
        raise ModelError(f"--dof: {dof} is not valid; expected a DOF of the branch (0 to "
                         f"{n - 1})")
    return d


def _gap(ds: xr.Dataset, gap: int | None) -> int:
    n = ds.sizes.get("gap", 0)
    g = 0 if gap is None else int(gap)
    if not 0 <= g < n:
        raise ModelError(f"--gap: {gap} is not valid; expected a gap of the branch (0 to "
                         f"{n - 1})" if n else f"--gap: {gap} is not valid; the branch's "
                         "model has no gap")
    return g


def branch_values(ds: xr.Dataset, quantity: str = "amplitude", dof: int | None = None,
                  gap: int | None = None) -> NDArray[np.float64]:
    """The value of ``quantity`` (:data:`BRANCH_QUANTITIES`) at every point of the branch."""
    if quantity not in BRANCH_QUANTITIES:
        raise ModelError(f"--quantity: {quantity!r} is not valid; expected one of "
                         f"{', '.join(BRANCH_QUANTITIES)}")
    if quantity == "impact-velocity":
        return np.asarray(ds["impact_speed_max"].values[:, _gap(ds, gap)], dtype=float)
    d = _dof(ds, dof)
    if quantity == "displacement":
        return np.asarray(ds["state"].values[:, d], dtype=float)
    return np.maximum(np.abs(ds["displacement_max"].values[:, d]),
                      np.abs(ds["displacement_min"].values[:, d]))


def _y_label(ds: xr.Dataset, quantity: str, dof: int | None, gap: int | None) -> str:
    from vibroimpact.io.results_file import dof_units

    text, unit = BRANCH_QUANTITIES[quantity]
    if unit is None:
        d = _dof(ds, dof)
        return f"{text}, DOF {d} [{dof_units(ds)[d]}]"
    return f"{text}, gap {_gap(ds, gap)} [{unit}]"


def _sweep_under(sweep: Any, ax: Axes, ds: xr.Dataset, quantity: str, dof: int | None,
                 gap: int | None) -> None:
    """The sweep's counterpart of ``quantity`` against the same parameter, as grey dots."""
    from vibroimpact.sweeps.plot import sweep_dataset

    sw = sweep_dataset(sweep)
    path = ds["parameter"].attrs["path"]
    if path not in json.loads(sw.attrs["params"]):
        raise ModelError(f"--sweep: the sweep does not vary {path}; expected a sweep over the "
                         "branch's parameter")
    x = sw[path].values
    if quantity == "impact-velocity":
        y = np.abs(sw["impact_velocity"].isel(gap=_gap(ds, gap)).transpose(path, ...).values)
    elif quantity == "displacement":
        y = sw["poincare_displacement"].isel(dof=_dof(ds, dof)).transpose(path, ...).values
    else:
        d = _dof(ds, dof)
        y = np.maximum(np.abs(sw["displacement_max"].isel(dof=d).values),
                       np.abs(sw["displacement_min"].isel(dof=d).values))[:, None]
    xs = np.repeat(x[:, None], y.shape[1], axis=1)
    ok = np.isfinite(y)
    ax.scatter(xs[ok], y[ok], s=3, color="0.6", linewidths=0, label="sweep (simulation)",
               rasterized=True, zorder=1)


def branch_diagram(ds: xr.Dataset, ax: Axes, *, quantity: str = "amplitude",
                   dof: int | None = None, gap: int | None = None, sweep: Any = None) -> None:
    """The branch's ``quantity`` against its parameter: solid where the orbit is stable,
    dashed where not (one line per run of equal stability, joined at the change), each
    special point marked and named; with ``sweep`` (a sweep Dataset or file over the same
    parameter) its counterpart under it: the sweep's amplitudes, Poincaré samples or impact
    speeds."""
    from vibroimpact.sweeps.grid import units_of

    y = branch_values(ds, quantity, dof, gap)
    x = np.asarray(ds["parameter"].values, dtype=float)
    stable = np.asarray(ds["stable"].values, dtype=bool)
    if sweep is not None:
        _sweep_under(sweep, ax, ds, quantity, dof, gap)
    start, labelled = 0, set()
    for k in range(1, len(x) + 1):
        if k == len(x) or stable[k] != stable[start]:
            label = "stable" if stable[start] else "unstable"
            end = min(k + 1, len(x))  # joined to the next run's first point
            ax.plot(x[start:end], y[start:end], color="C0", lw=1.5,
                    linestyle="-" if stable[start] else "--",
                    label=label if label not in labelled else "_nolegend_")
            labelled.add(label)
            start = k
    arclength = np.asarray(ds["arclength"].values, dtype=float)
    for i, kind in enumerate(np.asarray(ds["special_type"].values).astype(str)):
        s = float(ds["special_arclength"].values[i])
        value = float(ds["special_value"].values[i])
        yi = float(np.interp(s, arclength, y))
        ax.plot([value], [yi], marker=_MARKERS[kind], color="C3", linestyle="none",
                label=f"_{kind}")
        ax.annotate(kind, (value, yi), textcoords="offset points", xytext=(4, 4),
                    fontsize="x-small", color="C3")
    path = ds["parameter"].attrs["path"]
    unit = ds["parameter"].attrs.get("units") or units_of(path)
    ax.set_xlabel(f"{path} [{unit}]" if unit else path)
    ax.set_ylabel(_y_label(ds, quantity, dof, gap))


def multiplier_plane(ds: xr.Dataset, ax: Axes) -> None:
    """Every point's Floquet multipliers in the complex plane, coloured by the parameter, with
    the unit circle (outside it: unstable) and the special points' multipliers marked."""
    theta = np.linspace(0.0, 2 * np.pi, 361)
    ax.plot(np.cos(theta), np.sin(theta), color="0.3", lw=1.0, label="unit circle")
    re, im = ds["multiplier_real"].values, ds["multiplier_imag"].values
    p = np.repeat(np.asarray(ds["parameter"].values)[:, None], re.shape[1], axis=1)
    points = ax.scatter(re.ravel(), im.ravel(), c=p.ravel(), s=8, cmap="viridis",
                        label="multipliers", zorder=2)
    path = ds["parameter"].attrs["path"]
    unit = ds["parameter"].attrs.get("units", "")
    ax.figure.colorbar(points, ax=ax, label=f"{path} [{unit}]" if unit else path)
    for i, kind in enumerate(np.asarray(ds["special_type"].values).astype(str)):
        ax.plot(ds["special_multiplier_real"].values[i], ds["special_multiplier_imag"].values[i],
                marker=_MARKERS[kind], color="C3", linestyle="none", label=f"_{kind}", zorder=3)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("Re(multiplier) [-]")
    ax.set_ylabel("Im(multiplier) [-]")


def plot_branch(source: xr.Dataset | str | os.PathLike[str], kind: str = "branch", *,
                quantity: str = "amplitude", dof: int | None = None, gap: int | None = None,
                sweep: Any = None, ax: Axes | None = None,
                path: str | os.PathLike[str] | None = None, title: str | None = None
                ) -> Figure:
    """Draw a branch (a Dataset or a file of ``vibroimpact continue -o``) as ``kind``
    (:data:`BRANCH_KINDS`; ``quantity``, ``dof``, ``gap`` and ``sweep``: ``branch`` only) into
    ``ax`` or a new figure; saved to ``path`` if given. Returns the figure."""
    from vibroimpact.plotting import new_figure, save_figure

    if kind not in BRANCH_KINDS:
        raise ModelError(f"--kind: {kind!r} is not valid; expected one of "
                         f"{', '.join(BRANCH_KINDS)}")
    ds = branch_dataset(source)
    if ax is None:
        fig, ax = new_figure(width=5.5 if kind == "multipliers" else 7.0)
    else:
        fig = ax.figure
    if kind == "branch":
        branch_diagram(ds, ax, quantity=quantity, dof=dof, gap=gap, sweep=sweep)
    else:
        multiplier_plane(ds, ax)
    ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    ax.set_title(title or ("branch of periodic orbits" if kind == "branch"
                           else "Floquet multipliers"))
    if path is not None:
        save_figure(fig, path)
    return fig


def cli_plot(args: Any) -> int:
    """``vibroimpact plot BRANCH.nc --kind branch|multipliers -o FIG``: uses ``--sweep``,
    ``--quantity``, ``--dof``, ``--gap`` and ``--title`` of the plot command."""
    options = {"quantity": args.quantity, "dof": (args.dofs or [None])[0],
               "gap": (args.gaps or [None])[0], "sweep": args.sweep}
    if args.kind == "multipliers":
        given = [f"--{k}" for k, v in options.items() if v is not None]
        if given:
            raise ModelError(f"{given[0]}: not an option of --kind multipliers; it takes no "
                             "options")
    options["quantity"] = options["quantity"] or "amplitude"
    plot_branch(args.result, args.kind, path=args.output, title=args.title,
                **(options if args.kind == "branch" else {}))
    return 0
