"""The energy account over time (docs/conventions.md §What a run returns)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vibroimpact.plotting._data import time_mask

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes

#: The curves drawn, in order: name in the legend, and the term (``energy_<term>``) or a
#: derived quantity.
ENERGY_CURVES = (
    ("kinetic", "kinetic"),
    ("strain", "strain"),
    ("contact potential", "contact_potential"),
    ("total (kinetic + strain + contact)", "total"),
    ("external work", "external_work"),
    ("dissipated by damping", "damping_dissipated"),
    ("dissipated by contact", "contact_dissipated"),
    ("balance error", "balance"),
)


def energy(
    ds: xr.Dataset,
    ax: Axes,
    *,
    label: str | None = None,
    t_min: float | None = None,
    t_max: float | None = None,
    **style: Any,
) -> None:
    """Each term of the energy account, their total and the balance
    ``total + dissipated − total(0) − external work`` (zero up to the time discretisation)."""
    from vibroimpact.io.results_file import energy_frame

    mask = time_mask(ds, t_min, t_max)
    frame = energy_frame(ds)
    t = ds["time"].values[mask]
    prefix = "" if label is None else f"{label}: "
    for name, term in ENERGY_CURVES:
        values = frame[f"{term} [J]"].to_numpy()[mask]
        ax.plot(t, values, label=prefix + name, **style)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy [J]")
