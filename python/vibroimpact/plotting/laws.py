"""Contact laws compared on one impact (the paper's Figs. 3–4): force–indentation loops and
velocity–indentation curves, one curve per law.

    from vibroimpact import contact
    from vibroimpact.laws_compare import comparison_laws
    from vibroimpact.plotting.laws import plot_laws

    laws = comparison_laws(0.5, 0.04, 0.3, stiffness=1.509e11,
                           laws=["hertz", "hunt-crossley", "lankarani-nikravesh", "flores"])
    fig = plot_laws(laws, mass=0.04, velocity=0.3, path="laws.png")

Each law's impact is run by the core (:func:`vibroimpact.impact.single_impact_result`): the
body touches the wall at ``t = 0`` at ``velocity`` and is followed until it separates.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from vibroimpact.contact import ContactLaw
from vibroimpact.impact import single_impact_result

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from vibroimpact.result import Result

__all__ = ["contact_curves", "force_indentation_loops", "plot_laws",
           "velocity_indentation_curves"]

#: Points kept per curve at most (the runs have about 200 steps per contact, see
#: :data:`vibroimpact.impact.STEPS_PER_CONTACT`).
MAX_POINTS = 2000


def contact_curves(result: Result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Penetration δ (m), contact force (N) and penetration rate dδ/dt (m/s) of gap 0 of a
    single-impact run while in contact, closed at δ = 0 at both ends."""
    pen = np.asarray(result.gap_penetration)[:, 0]
    force = np.asarray(result.gap_force)[:, 0]
    rate = np.asarray(result.velocity)[:, 0]  # the wall is at +clearance: δ̇ = ẋ
    closed = np.flatnonzero(pen > 0.0)
    if closed.size == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    first, last = closed[0], closed[-1]
    lo, hi = max(first - 1, 0), min(last + 2, len(pen))
    step = max(1, (hi - lo) // MAX_POINTS)
    idx = np.unique(np.concatenate([np.arange(lo, hi, step), [hi - 1]]))
    return np.maximum(pen[idx], 0.0), force[idx], rate[idx]


def _runs(laws: Mapping[str, ContactLaw], mass: float, velocity: float) -> dict[str, Result]:
    return {name: single_impact_result(law, mass, velocity) for name, law in laws.items()}


def _style(i: int, n: int) -> dict[str, Any]:
    """Distinct colours for up to 20 curves (tab10, then tab20), dashes past 10."""
    import matplotlib

    if n <= 10:
        return {"color": matplotlib.colormaps["tab10"](i % 10)}
    return {"color": matplotlib.colormaps["tab20"](i % 20),
            "linestyle": "-" if i % 2 == 0 else "--"}


def force_indentation_loops(runs: Mapping[str, Result], ax: Axes, **style: Any) -> Axes:
    """Contact force against penetration, one loop per run (paper Fig. 3): the loop's area
    is the energy the law dissipates."""
    for i, (name, result) in enumerate(runs.items()):
        pen, force, _ = contact_curves(result)
        ax.plot(pen, force, label=name, **{**_style(i, len(runs)), **style})
    ax.set_xlabel("penetration δ [m]")
    ax.set_ylabel("contact force F [N]")
    ax.grid(True, alpha=0.3)
    return ax


def velocity_indentation_curves(runs: Mapping[str, Result], ax: Axes, **style: Any) -> Axes:
    """Penetration rate against penetration, one curve per run (paper Fig. 4): from the
    approach speed at δ = 0 to minus the separation speed."""
    for i, (name, result) in enumerate(runs.items()):
        pen, _, rate = contact_curves(result)
        ax.plot(pen, rate, label=name, **{**_style(i, len(runs)), **style})
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    ax.set_xlabel("penetration δ [m]")
    ax.set_ylabel("penetration rate dδ/dt [m/s]")
    ax.grid(True, alpha=0.3)
    return ax


def plot_laws(
    laws: Mapping[str, ContactLaw],
    mass: float,
    velocity: float,
    *,
    path: str | os.PathLike[str] | None = None,
    title: str | None = None,
) -> Figure:
    """Both figures side by side for the laws ``{name: law}`` (e.g. from
    :func:`vibroimpact.laws_compare.comparison_laws`); saved to ``path`` (.png, .svg, .pdf)
    if given. Returns the figure (no GUI backend needed)."""
    from vibroimpact.plotting import new_figure, save_figure

    runs = _runs(laws, mass, velocity)
    fig, (left, right) = new_figure(1, 2, width=12.5, height=4.4)
    force_indentation_loops(runs, left)
    velocity_indentation_curves(runs, right)
    left.set_title("force–indentation")
    right.set_title("velocity–indentation")
    fig.legend(*left.get_legend_handles_labels(), loc="outside right center", fontsize="small")
    fig.suptitle(title or f"one impact: m = {mass:g} kg, v0 = {velocity:g} m/s")
    if path is not None:
        save_figure(fig, path)
    return fig
