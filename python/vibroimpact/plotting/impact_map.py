"""Impact maps: the approach speed of every contact against the instant it began, or against
the phase of the forcing (a stroboscopic view of periodic and chaotic impacting)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from vibroimpact.errors import ModelError
from vibroimpact.plotting._data import harmonic_period, select
from vibroimpact.plotting.time_history import line_label

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes


def impact_map(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    gaps: Sequence[int] | int | None = None,
    x: str = "time",
    period: float | None = None,
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """Approach speed ``v_in`` of each contact (one marker series per gap) against its start
    time (``x="time"``) or against the forcing phase ``(t mod T)/T`` (``x="phase"``; ``period``
    T in s, default the period of the model's first harmonic load)."""
    if x not in ("time", "phase"):
        raise ModelError(f"--x: {x!r} is not valid; expected time or phase")
    if x == "phase":
        period = harmonic_period(ds) if period is None else period
        if period is None or not period > 0:
            raise ModelError("--period: missing; expected the forcing period in s (the model "
                             "has no harmonic load to take it from)")
    t = ds["impact_t_start"].values if "impact_t_start" in ds else np.empty(0)
    v = ds["impact_v_in"].values if "impact_v_in" in ds else np.empty(0)
    g = ds["impact_gap"].values if "impact_gap" in ds else np.empty(0, dtype=int)
    keep = np.ones(t.shape, dtype=bool)
    if t_min is not None:
        keep &= t >= t_min
    if t_max is not None:
        keep &= t <= t_max
    chosen = select(ds, "gap", gaps)
    style = {"marker": "o", "linestyle": "none", "markersize": 4, **style}
    for _, index in chosen:
        rows = keep & (g == index)
        xs = t[rows] if x == "time" else np.mod(t[rows], period) / period
        ax.plot(xs, v[rows], label=line_label(label, "gap", index, len(chosen) > 1), **style)
    ax.set_xlabel("contact start time [s]" if x == "time" else "forcing phase (t mod T)/T [-]")
    ax.set_ylabel("approach speed v_in [m/s]")
