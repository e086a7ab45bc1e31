"""The contact as the laws see it: force against indentation (the hysteresis loop of paper
Fig. 3) and indentation rate against indentation (paper Fig. 4)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from vibroimpact.plotting._data import penetration_rate, select, time_mask
from vibroimpact.plotting.time_history import line_label

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes


def _in_contact(values: np.ndarray, penetration: np.ndarray) -> np.ndarray:
    """``values`` where the gap is closed, NaN elsewhere (so separate contacts are separate
    curves); the samples just before and after a contact are kept to close the curve at 0."""
    closed = penetration > 0.0
    keep = closed.copy()
    keep[1:] |= closed[:-1]
    keep[:-1] |= closed[1:]
    return np.where(keep, values, np.nan)


def _clip(pen: np.ndarray) -> np.ndarray:
    return np.maximum(pen, 0.0)


def force_indentation(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    gaps: Sequence[int] | int | None = None,
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """Contact force against penetration δ during contact, one curve per gap; a dissipative
    law draws a loop whose area is the energy lost."""
    mask = time_mask(ds, t_min, t_max)
    chosen = select(ds, "gap", gaps)
    for pos, index in chosen:
        pen = ds["penetration"].values[mask, pos]
        force = ds["contact_force"].values[mask, pos]
        ax.plot(_in_contact(_clip(pen), pen), _in_contact(force, pen),
                label=line_label(label, "gap", index, len(chosen) > 1), **style)
    ax.set_xlabel("penetration δ [m]")
    ax.set_ylabel("contact force [N]")


def velocity_indentation(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    gaps: Sequence[int] | int | None = None,
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """Penetration rate dδ/dt against penetration δ during contact, one curve per gap: it
    starts at the approach speed and ends at minus the separation speed."""
    mask = time_mask(ds, t_min, t_max)
    chosen = select(ds, "gap", gaps)
    for pos, index in chosen:
        pen = ds["penetration"].values[mask, pos]
        rate = penetration_rate(ds, pos)[mask]
        ax.plot(_in_contact(_clip(pen), pen), _in_contact(rate, pen),
                label=line_label(label, "gap", index, len(chosen) > 1), **style)
    ax.set_xlabel("penetration δ [m]")
    ax.set_ylabel("penetration rate dδ/dt [m/s]")
