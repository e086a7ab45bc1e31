"""Amplitude spectra (FFT) of the time histories."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from vibroimpact.errors import ModelError
from vibroimpact.plotting._data import select, time_mask
from vibroimpact.plotting.time_history import TIME_HISTORIES, axis_label, line_label

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes


def amplitude_spectrum(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Single-sided amplitude spectrum of ``y(t)`` with a Hann window (a sine of amplitude A
    shows a peak of height ≈ A): ``(frequency [Hz], amplitude)``. Unevenly spaced samples
    (adaptive steps) are first interpolated onto a uniform grid with the median step."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if len(t) < 4:
        return np.zeros(0), np.zeros(0)
    steps = np.diff(t)
    h = float(np.median(steps))
    if not np.allclose(steps, h, rtol=1e-6, atol=0):
        grid = np.arange(t[0], t[-1] + 0.5 * h, h)
        y, t = np.interp(grid, t, y), grid
    window = np.hanning(len(y))
    spec = np.fft.rfft((y - y.mean()) * window)
    amp = 2.0 * np.abs(spec) / window.sum()
    return np.fft.rfftfreq(len(y), h), amp


def spectrum(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    quantity: str = "displacement",
    dofs: Sequence[int] | int | None = None,
    gaps: Sequence[int] | int | None = None,
    t_min: float | None = None,
    t_max: float | None = None,
    f_max: float | None = None,
    **style: Any,
) -> None:
    """Amplitude spectrum of ``quantity`` (displacement, velocity, acceleration,
    contact-force or penetration), one curve per selected DOF or gap, log scale."""
    if quantity not in TIME_HISTORIES:
        raise ModelError(f"--quantity: {quantity!r} is not valid; expected one of "
                         f"{', '.join(TIME_HISTORIES)}")
    var, _, dim = TIME_HISTORIES[quantity]
    mask = time_mask(ds, t_min, t_max)
    t = ds["time"].values[mask]
    chosen = select(ds, dim, dofs if dim == "dof" else gaps)
    positive = False
    for pos, index in chosen:
        f, a = amplitude_spectrum(t, ds[var].values[mask, pos])
        if f_max is not None:
            a, f = a[f <= f_max], f[f <= f_max]
        ax.plot(f[1:], a[1:], label=line_label(label, dim, index, len(chosen) > 1), **style)
        positive = positive or bool(np.any(a[1:] > 0))
    # log scale, unless nothing is > 0 (a body at rest): matplotlib cannot log-scale that
    ax.set_yscale("log" if positive else "linear")
    ax.set_xlabel("frequency [Hz]")
    name, unit = axis_label(ds, quantity, [pos for pos, _ in chosen]).split(" [", 1)
    ax.set_ylabel(f"{name.split(' (')[0]} amplitude [{unit.split(']')[0]}]")
