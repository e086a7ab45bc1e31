"""Plots of results (matplotlib; no GUI needed: figures are built with
:class:`matplotlib.figure.Figure` and saved as PNG, SVG or PDF). Every axis label carries its
unit (SI).

Each kind in :data:`KINDS` draws one result into one ``Axes``::

    import vibroimpact as vi
    from vibroimpact import plotting
    fig = plotting.plot(result, "force-indentation", path="loop.png")
    fig = plotting.compare({"Hertz": r1, "Flores": r2}, "velocity-indentation")
    result.plot("phase", dofs=[0])            # the same, as a method of the result

and ``vibroimpact plot RESULT.nc --kind KIND -o FIGURE.png`` draws a saved result. A source is a
:class:`~vibroimpact.Result`, an ``xarray.Dataset`` or a result file
(:mod:`vibroimpact.io.results_file`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vibroimpact.errors import ModelError
from vibroimpact.plotting._data import Source, dataset
from vibroimpact.plotting.contact import force_indentation, velocity_indentation
from vibroimpact.plotting.energy import ENERGY_CURVES, energy
from vibroimpact.plotting.impact_map import impact_map
from vibroimpact.plotting.modes import mode_shapes
from vibroimpact.plotting.orbit import orbit
from vibroimpact.plotting.phase import phase_portrait
from vibroimpact.plotting.spectrum import amplitude_spectrum, spectrum
from vibroimpact.plotting.time_history import TIME_HISTORIES, time_history

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "ENERGY_CURVES",
    "FIGURE_SUFFIXES",
    "KINDS",
    "Kind",
    "amplitude_spectrum",
    "compare",
    "draw",
    "new_figure",
    "plot",
    "save_figure",
]

#: Figure formats, by file suffix.
FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


@dataclass(frozen=True)
class Kind:
    """A plot kind: ``draw(ds, ax, label=..., **options)`` and what it shows.
    ``options`` names the keyword options it accepts besides ``label``, ``t_min``, ``t_max``
    and matplotlib line style keywords."""

    name: str
    draw: Callable[..., None]
    description: str
    options: tuple[str, ...] = ()


def _history(kind: str) -> Callable[..., None]:
    def draw(ds: xr.Dataset, ax: Axes, **options: Any) -> None:
        time_history(ds, ax, kind, **options)

    draw.__doc__ = time_history.__doc__
    return draw


#: Every plot kind by name.
KINDS: dict[str, Kind] = {
    **{
        name: Kind(name, _history(name), f"{TIME_HISTORIES[name][1]} against time",
                   ("dofs",) if TIME_HISTORIES[name][2] == "dof" else ("gaps",))
        for name in TIME_HISTORIES
    },
    "force-indentation": Kind("force-indentation", force_indentation,
                              "contact force against penetration (hysteresis loops)", ("gaps",)),
    "velocity-indentation": Kind("velocity-indentation", velocity_indentation,
                                 "penetration rate against penetration", ("gaps",)),
    "phase": Kind("phase", phase_portrait, "phase portrait: velocity against displacement",
                  ("dofs",)),
    "energy": Kind("energy", energy, "energy account against time"),
    "impact-map": Kind("impact-map", impact_map,
                       "approach speed of each contact against its time or forcing phase",
                       ("gaps", "x", "period")),
    "spectrum": Kind("spectrum", spectrum, "FFT amplitude spectrum",
                     ("quantity", "dofs", "gaps", "f_max")),
    "orbit": Kind("orbit", orbit, "rotor orbit: y against x at two DOFs (--dof IX --dof IY) "
                  "or at a node (--node N), with the stator's clearance circle (--clearance, "
                  "--center)", ("dofs", "node", "clearance", "center")),
    "mode-shapes": Kind("mode-shapes", mode_shapes,
                        "mode shapes of the result's structure (from its M and K)",
                        ("n_modes", "include_rigid")),
}

_COMMON = ("label", "t_min", "t_max")


def new_figure(rows: int = 1, cols: int = 1, *, width: float = 7.0,
               height: float | None = None) -> tuple[Figure, Any]:
    """A figure not tied to any GUI (safe with any backend, in threads and on servers) and its
    axes (one ``Axes`` or an array)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height or 3.6 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=True)
    return fig, axes


def _kind(kind: str) -> Kind:
    if kind not in KINDS:
        raise ModelError(f"--kind: {kind!r} is not valid; expected one of {', '.join(KINDS)}")
    return KINDS[kind]


def draw(source: Source, kind: str, ax: Axes, **options: Any) -> Axes:
    """Draw ``source`` as ``kind`` into ``ax`` (see :data:`KINDS`); returns ``ax``."""
    k = _kind(kind)
    ds = dataset(source)
    unknown = sorted(o for o in options if o not in (*k.options, *_COMMON)
                     and o not in _STYLE_KEYS)
    if unknown:
        raise ModelError(f"{unknown[0]}: not an option of plot kind {kind!r}; expected one of "
                         f"{', '.join((*k.options, *_COMMON))}")
    k.draw(ds, ax, **options)
    labelled = [line for line in ax.get_lines() if not line.get_label().startswith("_")]
    if len(labelled) > 1:
        # matplotlib's "best" placement scans every point: slow on long runs
        points = sum(len(line.get_xdata()) for line in ax.get_lines())
        ax.legend(fontsize="small", loc="best" if points < 50_000 else "upper right")
    ax.grid(True, alpha=0.3)
    return ax


_STYLE_KEYS = {"color", "linestyle", "linewidth", "marker", "markersize", "alpha", "zorder"}


def save_figure(fig: Figure, path: str | os.PathLike[str], *, dpi: int = 120) -> Path:
    """Save ``fig`` atomically as PNG, SVG or PDF (by the suffix of ``path``)."""
    from vibroimpact.io.results_file import atomic_write

    path = Path(path)
    fmt = path.suffix.lower()
    if fmt not in FIGURE_SUFFIXES:
        raise ModelError(f"-o: {str(path)!r} is not valid; expected a file name ending in "
                         f"{', '.join(FIGURE_SUFFIXES)}")
    atomic_write({path: lambda p: fig.savefig(p, format=fmt[1:], dpi=dpi,
                                              metadata=_figure_metadata(fmt))})
    return path


def _figure_metadata(fmt: str) -> dict[str, Any]:
    # reproducible files: no creation date in SVG/PDF
    if fmt == ".svg":
        return {"Date": None}
    if fmt == ".pdf":
        return {"CreationDate": None}
    return {}


def plot(
    source: Source,
    kind: str = "displacement",
    *,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
    title: str | None = None,
    **options: Any,
) -> Figure:
    """Draw ``source`` (a Result, a Dataset or a result file) as ``kind`` into ``ax`` or a new
    figure; save it to ``path`` if given. Returns the figure.

    **Options** (by kind, see :data:`KINDS`): ``dofs``/``gaps`` (labels to show, default all),
    ``t_min``/``t_max`` (s), ``label`` (legend entry), ``x="time"|"phase"`` and ``period``
    (impact-map), ``quantity`` and ``f_max`` (spectrum), ``clearance`` and ``center``
    (orbit), and matplotlib line styles.
    """
    if ax is None:
        fig, ax = new_figure()
    else:
        fig = ax.figure
    draw(source, kind, ax, **options)
    if title:
        ax.set_title(title)
    if path is not None:
        save_figure(fig, path)
    return fig


def compare(
    sources: Mapping[str, Source],
    kind: str,
    *,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
    title: str | None = None,
    **options: Any,
) -> Figure:
    """Overlay several results (``{label: source}``) as ``kind`` in one axes, e.g. the same
    case with each contact law; save to ``path`` if given."""
    if ax is None:
        fig, ax = new_figure()
    else:
        fig = ax.figure
    for label, source in sources.items():
        draw(source, kind, ax, label=label, **options)
    if title:
        ax.set_title(title)
    if path is not None:
        save_figure(fig, path)
    return fig
