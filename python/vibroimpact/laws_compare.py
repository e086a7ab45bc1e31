"""Comparing contact laws on one impact (``vibroimpact laws``; the paper's Figs. 3–4).

Every law of :data:`vibroimpact.contact.FORCE_LAWS` is given the same stiffness ``K``, exponent
``n`` and restitution ``ce`` and strikes a rigid wall with the same mass and speed; the core
computes the effective restitution, peak indentation, peak force and contact duration
(:func:`vibroimpact.impact.single_impact`). Three laws take other parameters, derived here:

* ``hertz`` ignores ``ce`` (elastic);
* ``kelvin-voigt`` gets the linear stiffness ``k = m v²/δ_H²`` that stores the impact energy
  at the Hertz peak indentation ``δ_H = ((n+1) m v²/(2K))^(1/(n+1))``, and the dashpot with
  which its clamped contact restitutes ``ce`` exactly
  (:func:`~vibroimpact.contact.kelvin_voigt_damping`, as ``vibroimpact impact`` with
  ``--restitution``);
* ``tabulated`` gets the loading curve ``K δⁿ`` through :data:`TABLE_POINTS` points up to
  ``δ_e = 1.5 δ_H`` and the unloading curve ``K δ_eⁿ (δ/δ_e)^m``, ``m = (n+1)/ce² − 1``,
  through :data:`UNLOADING_POINTS` points: stretched to start at any largest penetration
  ``δ_m`` of the power-law loading curve it returns the fraction ``(n+1)/(m+1) = ce²`` of
  the stored energy.

:func:`restitution_table` is the effective restitution of every law against ``ce``, rendered
by :func:`render_restitution_table` (the table of ``docs/contact-laws.md``, written by
``python -m vibroimpact.docs`` and checked by the tests).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vibroimpact.contact import (
    FORCE_LAWS,
    RESTITUTION_LAWS,
    ContactLaw,
    Geometry,
    HuntCrossley,
    KelvinVoigt,
    Tabulated,
    check_parameter,
    kelvin_voigt_damping,
    refuse_removed_law,
)
from vibroimpact.errors import require
from vibroimpact.impact import hertz_estimate, single_impact

__all__ = [
    "COMPARE_FIELDS",
    "DESIGN_ACCURACY",
    "DOC_RESTITUTIONS",
    "DesignAccuracy",
    "compare_laws",
    "comparison_laws",
    "render_restitution_table",
    "restitution_table",
]

#: The fields of each law's entry, as ``vibroimpact impact --json`` prints them.
COMPARE_FIELDS = ("delta_max", "force_max", "duration", "v_out", "restitution_effective")

#: Points of the tabulated loading curve built for a comparison.
TABLE_POINTS = 101

#: Points of its unloading curve (``δ^m`` is steep for small ce: 1001 points keep the energy
#: it returns within 0.1 % of ``ce²``).
UNLOADING_POINTS = 1001

#: The restitutions of the documented table.
DOC_RESTITUTIONS = (0.1, 0.3, 0.5, 0.7, 0.9, 0.99)

#: The impact of the documented table: the paper's two spheres (docs/paper-cases.md). For
#: the laws ``K δⁿ (1 + χ δ̇/v_imp)`` the effective restitution depends on χ only, not on these.
DOC_MASS, DOC_VELOCITY = 0.04, 0.3


def _resolve_stiffness(
    stiffness: float | Geometry, exponent: float | None
) -> tuple[float | Geometry, float, float]:
    if isinstance(stiffness, Geometry):
        n = stiffness.exponent if exponent is None else float(exponent)
        return stiffness, n, stiffness.stiffness()
    n = 1.5 if exponent is None else float(exponent)
    check_parameter("hertz", "stiffness", stiffness, field="stiffness")
    return float(stiffness), n, float(stiffness)


def comparison_laws(
    restitution: float,
    mass: float,
    velocity: float,
    stiffness: float | Geometry,
    exponent: float | None = None,
    laws: Iterable[str] | None = None,
) -> dict[str, ContactLaw]:
    """Each law (default: all of :data:`~vibroimpact.contact.FORCE_LAWS`, in that order) with the
    common stiffness, exponent (default: the geometry's, else 1.5) and restitution ``ce``;
    Kelvin–Voigt and the tabulated law get the equivalent parameters of the module docstring."""
    check_parameter("hunt-crossley", "restitution", restitution, field="restitution")
    require(isinstance(mass, (int, float)) and math.isfinite(mass) and mass > 0,
            "mass", mass, "a mass > 0 in kg")
    require(isinstance(velocity, (int, float)) and math.isfinite(velocity) and velocity > 0,
            "velocity", velocity, "an approach speed > 0 in m/s")
    k_or_geometry, n, k = _resolve_stiffness(stiffness, exponent)
    names = list(FORCE_LAWS) if laws is None else list(laws)
    for name in names:
        refuse_removed_law(name)
        require(name in FORCE_LAWS, "law", name, "one of " + ", ".join(FORCE_LAWS))
    peak = hertz_estimate(k, n, mass, velocity)["delta_max"]
    ce = float(restitution)
    out: dict[str, ContactLaw] = {}
    for name in names:
        if name == "hertz":
            out[name] = FORCE_LAWS[name](stiffness=k_or_geometry, exponent=n)  # type: ignore[call-arg]
        elif name == "kelvin-voigt":
            k_lin = mass * velocity * velocity / peak / peak
            out[name] = KelvinVoigt(stiffness=k_lin,
                                    damping=kelvin_voigt_damping(ce, k_lin, mass))
        elif name == "hunt-crossley":
            out[name] = HuntCrossley(stiffness=k_or_geometry, exponent=n, restitution=ce)
        elif name == "tabulated":
            end = 1.5 * peak
            x = np.linspace(0.0, end, TABLE_POINTS)
            xu = np.linspace(0.0, end, UNLOADING_POINTS)
            m = (n + 1.0) / ce**2 - 1.0
            out[name] = Tabulated(x, k * x**n, xu, k * end**n * (xu / end) ** m)
        else:
            assert name in RESTITUTION_LAWS
            out[name] = FORCE_LAWS[name](  # type: ignore[call-arg]
                stiffness=k_or_geometry, exponent=n, restitution=ce
            )
    return out


def compare_laws(
    restitution: float,
    mass: float,
    velocity: float,
    stiffness: float | Geometry,
    exponent: float | None = None,
    laws: Iterable[str] | None = None,
) -> dict[str, dict[str, float]]:
    """One impact per law (:func:`comparison_laws`): ``{law: {delta_max (m), force_max (N),
    duration (s), v_out (m/s), restitution_effective}}``."""
    built = comparison_laws(restitution, mass, velocity, stiffness, exponent, laws)
    out: dict[str, dict[str, float]] = {}
    for name, law in built.items():
        result = single_impact(law, mass, velocity)
        out[name] = {key: float(result[key]) for key in COMPARE_FIELDS}
    return out


def restitution_table(
    restitutions: Sequence[float] = DOC_RESTITUTIONS,
    laws: Iterable[str] | None = None,
    mass: float = DOC_MASS,
    velocity: float = DOC_VELOCITY,
    *,
    stiffness: float | Geometry,
    exponent: float | None = None,
) -> dict[str, dict[float, float]]:
    """Effective restitution of one impact, ``{law: {ce: e_eff}}``, computed by the core
    for the contact ``stiffness`` (a number in N/m^n or a :class:`Geometry`)."""
    names = list(FORCE_LAWS) if laws is None else list(laws)
    table: dict[str, dict[float, float]] = {name: {} for name in names}
    for ce in restitutions:
        for name, row in compare_laws(ce, mass, velocity, stiffness, exponent, names).items():
            table[name][ce] = row["restitution_effective"]
    return table


@dataclass(frozen=True)
class DesignAccuracy:
    """What a law built to reproduce ``ce`` is asserted to achieve: ``|e_eff − ce| <=
    tolerance`` for ``ce_min <= ce <= ce_max``, with the reason."""

    ce_min: float
    ce_max: float
    tolerance: float
    basis: str


#: The laws designed to reproduce ``ce`` and the accuracy the tests assert for them, over the
#: range each source proposes its law for (the tolerances are this project's reading of
#: those claims; the sources give them as figures, not numbers).
DESIGN_ACCURACY: dict[str, DesignAccuracy] = {
    "kelvin-voigt": DesignAccuracy(0.0, 1.0, 1e-8, "exact relation of the clamped contact; "
                                   "DOP853 locates its clamp"),
    "hunt-crossley": DesignAccuracy(0.9, 1.0, 0.01, "derived for ce near 1"),
    "herbert-mcwhannell": DesignAccuracy(0.9, 1.0, 0.002, "Hunt–Crossley's factor as ce → 1"),
    "lankarani-nikravesh": DesignAccuracy(0.9, 1.0, 0.015, "derived for ce near 1"),
    "gonthier": DesignAccuracy(0.1, 1.0, 0.035, "proposed for the whole range"),
    "zhiying-qishao": DesignAccuracy(0.3, 1.0, 0.03,
                                     "Lankarani–Nikravesh × e^{2(1−ce)}, for lower ce"),
    "flores": DesignAccuracy(0.1, 1.0, 0.05, "soft and hard materials: the whole range"),
    "ye": DesignAccuracy(0.1, 1.0, 0.05, "same factor as Flores et al."),
    "hu-guo": DesignAccuracy(0.1, 1.0, 0.03, "hard and soft materials: the whole range"),
    "gharib-hurmuzlu": DesignAccuracy(0.0, 0.1, 0.015, "proposed for low ce"),
    "carvalho-martins": DesignAccuracy(0.3, 1.0, 0.005,
                                       "closed form of the exact relation, ce ≳ 1/3"),
    "exact-restitution": DesignAccuracy(0.0, 1.0, 1e-6, "exact relation (see its docs page)"),
}


def _formula(name: str) -> str:
    return {
        "hertz": "elastic",
        "kelvin-voigt": "c = 2ζ√(km), 2ζ arccos ζ/√(1−ζ²) = −ln ce (clamped)",
        "hunt-crossley": "χ = 3(1−ce)/2",
        "herbert-mcwhannell": "χ = 6(1−ce)/[(2ce−1)²+3]",
        "lee-wang": "χ = 3(1−ce)/4",
        "lankarani-nikravesh": "χ = 3(1−ce²)/4",
        "gonthier": "χ = (1−ce²)/ce",
        "zhiying-qishao": "χ = 3(1−ce²)e^{2(1−ce)}/4",
        "flores": "χ = 8(1−ce)/(5ce)",
        "hu-guo": "χ = 3(1−ce)/(2ce)",
        "gharib-hurmuzlu": "χ = 1/ce − 1",
        "ye": "χ = 8(1−ce)/(5ce)",
        "carvalho-martins": "χ = 3(1−ce)(11−ce)/[2(1+9ce)]",
        "exact-restitution": "χ: root of χ−ln(1+χ) = −χce−ln(1−χce)",
        "tabulated": "unloading ∝ δ^m, m = (n+1)/ce²−1, from δ_max",
    }.get(name, "")


def render_restitution_table(table: Mapping[str, Mapping[float, float]]) -> str:
    """The markdown table of ``e_eff`` against ``ce`` (three decimals) of
    :func:`restitution_table`, as committed in ``docs/contact-laws.md``."""
    ces = sorted({ce for row in table.values() for ce in row})
    head = "| law | damping | " + " | ".join(f"ce = {ce:g}" for ce in ces) + " |"
    lines = [head, "|---|---|" + "---:|" * len(ces)]
    for name, row in table.items():
        cells = []
        for ce in ces:
            e = row[ce]
            acc = DESIGN_ACCURACY.get(name)
            inside = acc is not None and acc.ce_min <= ce <= acc.ce_max
            cells.append(f"**{e:.3f}**" if inside else f"{e:.3f}")
        lines.append(f"| `{name}` | {_formula(name)} | " + " | ".join(cells) + " |")
    lines += ["", "| law | designed for | asserted \\|e_eff − ce\\| | basis |",
              "|---|---|---:|---|"]
    for name, acc in DESIGN_ACCURACY.items():
        if name in table:
            lines.append(f"| `{name}` | {acc.ce_min:g} <= ce <= {acc.ce_max:g} | "
                         f"<= {acc.tolerance:g} | {acc.basis} |")
    return "\n".join(lines)


def _as_json(results: Mapping[str, Mapping[str, float]]) -> dict[str, Any]:
    return {name: {k: row[k] for k in COMPARE_FIELDS} for name, row in results.items()}
