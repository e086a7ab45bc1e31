"""Plots of sweeps: the bifurcation diagram (Poincaré samples, or impact speeds, against the
swept parameter) and the response curve (amplitude against the parameter, up- and down-sweeps
overlaid). Also ``vibroimpact plot SWEEP.nc --kind bifurcation|response -o FIG.png``."""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vibroimpact.errors import ModelError

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["SWEEP_KINDS", "cli_plot", "plot_bifurcation", "plot_response", "sweep_dataset"]

#: Plot kinds of sweep files: name -> description.
SWEEP_KINDS = {
    "bifurcation": "sweep: Poincare samples (or impact speeds) against the swept parameter",
    "response": "sweep: amplitude against the swept parameter, up- and down-sweeps",
    "waterfall": "sweep over structure.spin_speed (--samples-per-period N): full-spectrum "
                 "waterfall, forward and backward whirl (--dof IX --dof IY)",
}

#: Bifurcation quantities: variable, axis text, unit (None: the sampled DOF's, see
#: :func:`_dof_unit`).
_QUANTITIES = {
    "displacement": ("poincare_displacement", "displacement at the forcing phase", None),
    "velocity": ("poincare_velocity", "velocity at the forcing phase", None),
    "impact-velocity": ("impact_velocity", "approach speed at impact", "m/s"),
}

_RESPONSES = {
    "amplitude": "largest |displacement|",
    "peak-to-peak": "peak-to-peak displacement",
    "rms": "RMS displacement",
}


def sweep_dataset(source: Any) -> xr.Dataset:
    """The Dataset of a sweep (one returned by ``run_sweep`` or a file of ``vibroimpact
    sweep``); :class:`ModelError` for anything else."""
    if isinstance(source, (str, os.PathLike)):
        from vibroimpact.sweeps.runner import load_sweep

        return load_sweep(source)
    if getattr(source, "attrs", {}).get("kind") != "vibroimpact-sweep":
        raise ModelError("source: not a sweep; expected a Dataset returned by run_sweep or a "
                         "file written by vibroimpact sweep")
    return source


def _axis(ds: xr.Dataset, param: str | None, select: Mapping[str, float] | None
          ) -> tuple[str, xr.Dataset, str]:
    """The swept parameter on the x axis, the Dataset with the others selected, and a note
    saying which values the others were held at."""
    import json

    params = json.loads(ds.attrs["params"])
    if param is None:
        axis = ds.attrs.get("continuation_axis") or ""
        multi = [p for p in params if ds.sizes[p] > 1]
        param = axis or (multi[0] if multi else params[0])
    if param not in params:
        raise ModelError(f"param: {param!r} is not valid; expected one of {', '.join(params)}")
    select = dict(select or {})
    for p in params:
        if p != param and p not in select:
            select[p] = float(ds[p].values[0])
    unknown = [p for p in select if p not in params or p == param]
    if unknown:
        raise ModelError(f"select: {unknown[0]!r} is not valid; expected other swept "
                         f"parameters ({', '.join(p for p in params if p != param)})")
    sub = ds.sel({p: v for p, v in select.items()}, method="nearest") if select else ds
    note = ", ".join(f"{p} = {float(sub[p].values):g}" for p in select)
    return param, sub, note


def _label(ds: xr.Dataset, name: str) -> str:
    units = ds[name].attrs.get("units", "")
    return f"{name} [{units}]" if units and units != "1" else name


def _dof_unit(ds: xr.Dataset, dof: int, quantity: str) -> str:
    """The unit of ``quantity`` (``displacement``, ``velocity``) of the sampled DOF ``dof``:
    ``rad``, ``rad/s`` for a rotation (its ``dof_unit``; ``m`` in files written before it)."""
    from vibroimpact.io.results_file import dof_units
    from vibroimpact.result import dof_variable_units

    unit = dof_units(ds)[list(ds["dof"].values).index(dof)]
    return dof_variable_units(quantity, [unit])[1]


def _new(ax: Axes | None) -> tuple[Figure, Axes]:
    if ax is not None:
        return ax.figure, ax  # type: ignore[return-value]
    from vibroimpact.plotting import new_figure

    fig, ax = new_figure()
    return fig, ax


def _directions(ds: xr.Dataset) -> list[tuple[str, xr.Dataset]]:
    if "direction" in ds.dims:
        return [(str(d), ds.sel(direction=d)) for d in ds["direction"].values]
    cont = ds.attrs.get("continuation", "none")
    return [(cont if cont != "none" else "", ds)]


def plot_bifurcation(
    source: Any,
    *,
    quantity: str = "displacement",
    dof: int | None = None,
    gap: int = 0,
    param: str | None = None,
    select: Mapping[str, float] | None = None,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
    title: str | None = None,
) -> Figure:
    """Bifurcation diagram: every Poincaré sample (``quantity`` ``displacement`` or
    ``velocity`` of DOF ``dof``, default the first sampled) or every kept impact's approach
    speed (``impact-velocity`` of gap ``gap``) against the swept parameter ``param`` (default
    the continuation axis or the first with several values; the others are held at ``select``
    or their first value). Up- and down-sweeps in two colours. Saved to ``path`` if given."""
    if quantity not in _QUANTITIES:
        raise ModelError(f"--quantity: {quantity!r} is not valid; expected one of "
                         f"{', '.join(_QUANTITIES)}")
    ds = sweep_dataset(source)
    param, sub, note = _axis(ds, param, select)
    var, text, units = _QUANTITIES[quantity]
    fig, ax = _new(ax)
    for k, (direction, d) in enumerate(_directions(sub)):
        if quantity == "impact-velocity":
            if gap not in d["gap"].values:
                raise ModelError(f"--gap: {gap} is not valid; expected one of "
                                 f"{', '.join(map(str, d['gap'].values))}")
            y = d[var].sel(gap=gap).transpose(param, "impact").values
        else:
            dd = int(d["dof"].values[0]) if dof is None else dof
            if dd not in d["dof"].values:
                raise ModelError(f"--dof: {dd} is not valid; expected a sampled DOF "
                                 f"({', '.join(map(str, d['dof'].values))})")
            y = d[var].sel(dof=dd).transpose(param, "sample").values
        x = np.repeat(d[param].values[:, None], y.shape[1], axis=1)
        ok = np.isfinite(y)
        ax.scatter(x[ok], y[ok], s=1.5, color=f"C{k}", linewidths=0,
                   label=f"{direction}-sweep" if direction else None, rasterized=True)
    ax.set_xlabel(_label(ds, param))
    if units is None:
        dd = int(sub["dof"].values[0]) if dof is None else dof
        what, units = f"DOF {dd}", _dof_unit(sub, dd, quantity)
    else:
        what = f"gap {gap}"
    ax.set_ylabel(f"{text}, {what} [{units}]")
    if len(_directions(sub)) > 1:
        ax.legend(fontsize="small", markerscale=6)
    ax.grid(True, alpha=0.3)
    ax.set_title(title or ("bifurcation diagram" + (f" ({note})" if note else "")))
    if path is not None:
        from vibroimpact.plotting import save_figure

        save_figure(fig, Path(path))
    return fig


def plot_response(
    source: Any,
    *,
    quantity: str = "amplitude",
    dof: int | None = None,
    param: str | None = None,
    select: Mapping[str, float] | None = None,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
    title: str | None = None,
) -> Figure:
    """Response curve: ``amplitude`` (largest |x| after the transient), ``peak-to-peak`` or
    ``rms`` of DOF ``dof`` against the swept parameter; up- and down-sweeps as two lines
    (hysteresis), impacting points marked. Saved to ``path`` if given."""
    if quantity not in _RESPONSES:
        raise ModelError(f"--quantity: {quantity!r} is not valid; expected one of "
                         f"{', '.join(_RESPONSES)}")
    ds = sweep_dataset(source)
    param, sub, note = _axis(ds, param, select)
    fig, ax = _new(ax)
    dd = int(sub["dof"].values[0]) if dof is None else dof
    if dd not in sub["dof"].values:
        raise ModelError(f"--dof: {dd} is not valid; expected a sampled DOF "
                         f"({', '.join(map(str, sub['dof'].values))})")
    for k, (direction, d) in enumerate(_directions(sub)):
        hi = d["displacement_max"].sel(dof=dd)
        lo = d["displacement_min"].sel(dof=dd)
        if quantity == "amplitude":
            y = np.maximum(np.abs(hi), np.abs(lo))
        elif quantity == "peak-to-peak":
            y = hi - lo
        else:
            y = d["displacement_rms"].sel(dof=dd)
        x = d[param].values
        yv = np.asarray(y.transpose(param).values)
        ax.plot(x, yv, color=f"C{k}", lw=1.2,
                label=f"{direction}-sweep" if direction else None)
        impacting = d["impact_count"].sum("gap").transpose(param).values > 0
        ax.plot(x[impacting], yv[impacting], ".", color=f"C{k}", ms=3,
                label="_impacting")
    ax.set_xlabel(_label(ds, param))
    ax.set_ylabel(f"{_RESPONSES[quantity]}, DOF {dd} [{_dof_unit(sub, dd, 'displacement')}]")
    if len(_directions(sub)) > 1:
        ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    ax.set_title(title or ("response curve (dots: impacting)" + (f"; {note}" if note else "")))
    if path is not None:
        from vibroimpact.plotting import save_figure

        save_figure(fig, Path(path))
    return fig


def cli_plot(args: argparse.Namespace) -> int:
    """``vibroimpact plot SWEEP.nc --kind bifurcation|response -o FIG``: uses ``--dof``,
    ``--gap``, ``--quantity`` and ``--title`` of the plot command."""
    dofs = getattr(args, "dofs", None) or [None]
    gaps = getattr(args, "gaps", None) or [0]
    quantity = getattr(args, "quantity", None)
    title = getattr(args, "title", None)
    if args.kind == "waterfall":
        from vibroimpact.rotor import plot_waterfall

        plot_waterfall(args.result, dofs=getattr(args, "dofs", None), path=args.output,
                       title=title)
        return 0
    if args.kind == "bifurcation":
        plot_bifurcation(args.result, quantity=quantity or "displacement", dof=dofs[0],
                         gap=gaps[0], path=args.output, title=title)
    else:
        plot_response(args.result, quantity=quantity or "amplitude", dof=dofs[0],
                      path=args.output, title=title)
    return 0
