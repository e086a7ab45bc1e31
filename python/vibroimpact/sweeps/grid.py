"""Sweep parameters: a path to a numeric model parameter and its values, parsed from the
command line (``loads.0.frequency=5:50:400``), and applied to a model spec (by the core:
``_core.ModelSpec.with_value``).

Paths name a number of the model (the dict of :meth:`vibroimpact.Model.to_spec`), with the
model file's names; ``gaps[0].law.restitution`` and ``gaps.0.law.restitution`` are the same:

==================================  ==========================================================
``structure.mass``                  mass of a single-DOF structure, kg (``structure.mass.i.j``:
                                    entry ``(i, j)`` and ``(j, i)`` of the matrix)
``structure.stiffness``             likewise, N/m
``structure.damping``               likewise, N·s/m
``structure.spin_speed``            spin speed Ω of a rotor, rad/s (its gyroscopic forces and
                                    unbalance loads follow; a run-up's start)
``structure.spin_speed_end``        a run-up's final spin speed, rad/s
``structure.run_up_time``           a run-up's duration, s
``gaps.G.clearance``                clearance of gap ``G``, m
``gaps.G.law.KEY``                  a number of gap ``G``'s contact law: ``stiffness``
                                    (N/mⁿ), ``exponent``, ``restitution``, ``damping`` …
``gaps.G.coefficients.J``           coefficient ``J`` of the gap coordinate
``loads.L.amplitude``               amplitude of load ``L``, N
``loads.L.frequency``               frequency of harmonic load ``L``, Hz
``loads.L.phase``                   phase of harmonic or unbalance load ``L``, rad
``loads.L.magnitude``               unbalance m·e of load ``L``, kg·m
``initial.displacement[.I]``        initial displacement of DOF ``I`` (no index: single DOF), m
``initial.velocity[.I]``            initial velocity, m/s
==================================  ==========================================================
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vibroimpact import _core
from vibroimpact.errors import ModelError

__all__ = ["Param", "apply", "canonical_path", "numeric_paths", "parse_param", "units_of"]

#: Units of the parameters by their last name.
_UNITS = {
    "mass": "kg",
    "stiffness": "N/m",
    "damping": "N s/m",
    "clearance": "m",
    "amplitude": "N",
    "frequency": "Hz",
    "phase": "rad",
    "displacement": "m",
    "velocity": "m/s",
    "restitution": "1",
    "exponent": "1",
    "coefficients": "1",
    "spin_speed": "rad/s",
    "spin_speed_end": "rad/s",
    "run_up_time": "s",
    "magnitude": "kg m",
}

def canonical_path(path: str) -> str:
    """``gaps[0].law.restitution`` → ``gaps.0.law.restitution`` (whitespace removed)."""
    p = re.sub(r"\[\s*(\d+)\s*\]", r".\1", path.strip())
    return ".".join(part.strip() for part in p.split(".") if part.strip() != "")


def units_of(path: str) -> str:
    """SI unit of the parameter at ``path`` (``"1"`` for dimensionless)."""
    parts = canonical_path(path).split(".")
    named = [p for p in parts if not p.isdigit()]
    if named and named[0] == "gaps" and named[-1] == "stiffness":
        return "N/m^n"
    if named and named[0] == "gaps" and named[-1] == "damping":
        return "N s/m^n"
    return _UNITS.get(named[-1], "") if named else ""


@dataclass(frozen=True)
class Param:
    """A swept parameter: ``path`` (see the module doc) and its ``values``."""

    path: str
    values: NDArray[np.float64]

    def __init__(self, path: str, values: Sequence[float] | NDArray[np.float64]) -> None:
        p = canonical_path(path)
        if not p:
            raise ModelError(f"--param: {path!r} is not valid; expected a parameter path such "
                             "as loads.0.frequency")
        v = np.atleast_1d(np.asarray(values, dtype=float)).ravel()
        if v.size == 0 or not np.all(np.isfinite(v)):
            raise ModelError(f"--param {p}: {values!r} is not valid; expected one or more "
                             "finite numbers")
        v.setflags(write=False)
        object.__setattr__(self, "path", p)
        object.__setattr__(self, "values", v)

    @property
    def units(self) -> str:
        return units_of(self.path)

    def __len__(self) -> int:
        return int(self.values.size)

    def to_json(self) -> dict[str, Any]:
        return {"path": self.path, "values": [float(x) for x in self.values]}

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Param) and other.path == self.path
                and np.array_equal(other.values, self.values))

    def __hash__(self) -> int:
        return hash((self.path, self.values.tobytes()))


_SPEC_HELP = "PATH=A:B:N (N values from A to B), PATH=A:B:N:log or PATH=V1,V2,..."


def parse_param(text: str) -> Param:
    """``loads.0.frequency=5:50:400`` (linear), ``…=1e-4:1e-2:50:log`` (logarithmic) or
    ``…=0.5,0.7,0.9`` (a list)."""
    path, sep, spec = text.partition("=")
    if not sep or not path.strip() or not spec.strip():
        raise ModelError(f"--param: {text!r} is not valid; expected {_SPEC_HELP}")
    spec = spec.strip()
    bad = ModelError(f"--param {canonical_path(path)}: {spec!r} is not valid; expected "
                     f"{_SPEC_HELP}")
    if ":" in spec:
        parts = [s.strip() for s in spec.split(":")]
        log = len(parts) == 4 and parts[3].lower() == "log"
        if len(parts) not in (3, 4) or (len(parts) == 4 and not log):
            raise bad
        try:
            a, b = float(parts[0]), float(parts[1])
            n = int(parts[2])
        except ValueError:
            raise bad from None
        if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
            raise bad
        if log:
            if a <= 0 or b <= 0:
                raise ModelError(f"--param {canonical_path(path)}: {spec!r} is not valid; "
                                 "expected A > 0 and B > 0 for log spacing")
            values = np.geomspace(a, b, n)
        else:
            values = np.linspace(a, b, n)
        return Param(path, values)
    try:
        values = [float(s) for s in spec.split(",") if s.strip() != ""]
    except ValueError:
        raise bad from None
    if not values:
        raise bad
    return Param(path, values)


def numeric_paths(spec: Mapping[str, Any]) -> list[str]:
    """Every parameter path of ``spec`` (a :meth:`vibroimpact.Model.to_spec` dict) that a
    sweep can set (the core's ``ModelSpec.numeric_paths``)."""
    return _core.ModelSpec(dict(spec)).numeric_paths()


def apply(spec: Mapping[str, Any], path: str, value: float) -> dict[str, Any]:
    """A copy of ``spec`` with the parameter at ``path`` set to ``value``: the core's
    ``ModelSpec.with_value``, the one implementation of the paths, as a spec dict. Raises
    :class:`ModelError` naming the path and the paths that exist if ``path`` is not a numeric
    parameter of the model."""
    return _core.ModelSpec(dict(spec)).with_value(canonical_path(path), float(value)).to_dict()
