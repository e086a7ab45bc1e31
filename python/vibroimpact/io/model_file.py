"""Model files: a structure with clearances, its loads, initial state and solver settings in one
TOML file (docs/model-file.md; units and names: docs/conventions.md).

The accepted keys are data: :data:`SCHEMA` (one :class:`Field` per key: TOML path, type, unit,
default or required, allowed values, description) and :data:`RULES` (constraints between keys).
Both are read by :func:`load_model`, which checks a file against them and reports every mistake
of the file at once, and by :func:`render_reference`, which renders the reference committed as
``docs/model-file.md``. After changing the schema, a contact law or an integrator, regenerate it::

    python -m vibroimpact.docs        # every generated page of docs/, this one included

Example::

    >>> from vibroimpact.io import load_model
    >>> mf = load_model("examples/models/sdof_paper_ln.toml")  # doctest: +SKIP
    >>> result = mf.simulate()  # doctest: +SKIP
    >>> result.max_abs_displacement  # doctest: +SKIP
    array([0.00618624])
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
import re
import sys
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vibroimpact import contact, integrators
from vibroimpact.errors import ModelError, SolverError
from vibroimpact.fe.condensation import weighted_loads
from vibroimpact.fe.damping import damping_from_table
from vibroimpact.fe.dofs import DofMap, FEStructure
from vibroimpact.fe.matrices import FORMATS, SUFFIXES, read_dof_map, read_matrix_files
from vibroimpact.integrators import Integrator, method_from_options
from vibroimpact.model import (
    MODEL_CATALOG,
    ConstantLoad,
    Gap,
    HarmonicLoad,
    Load,
    Model,
    RadialGap,
    Structure,
    TableLoad,
    UnbalanceLoad,
    model_default,
)
from vibroimpact.simulate import check_run, contact_periods

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

if TYPE_CHECKING:
    from vibroimpact.fe.condensation import DofRecovery
    from vibroimpact.result import Result

__all__ = [
    "RULES",
    "SCHEMA",
    "SCHEMA_VERSION",
    "ExactlyOne",
    "Field",
    "ModelFile",
    "ModelFileError",
    "load_model",
    "render_reference",
]

#: The schema version this module reads (``schema_version`` in a model file).
SCHEMA_VERSION = 1


class ModelFileError(ModelError):
    """A model file has mistakes. ``errors`` holds one line per mistake (all of the file's
    mistakes, found before anything runs), each naming the TOML path of the key, the value and
    what was expected; ``str()`` is those lines joined by newlines."""

    def __init__(self, errors: Sequence[str]) -> None:
        self.errors = list(errors)
        super().__init__("\n".join(self.errors))


# --------------------------------------------------------------------------------------------
# The schema, as data
# --------------------------------------------------------------------------------------------


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


#: Marks a :class:`Field` without a default.
REQUIRED: Any = _Required()


@dataclass(frozen=True)
class Field:
    """One accepted key of a model file.

    ``path`` is the TOML path, ``[]`` marking an array of tables (``gaps[].law.restitution``);
    ``type`` a key of :data:`TYPES`; ``default`` a value, :data:`REQUIRED`, or None (optional,
    no value); ``when = (key, values)`` limits the key to tables whose sibling ``key`` has one
    of ``values`` (it is refused elsewhere); ``required_when`` likewise makes it required;
    ``rule`` states in words a check between keys that :func:`load_model` makes; ``open``
    (tables only) passes keys the schema does not list on to the integrator; ``removed`` maps
    values no longer among the ``choices`` to the line that says why and what to use.
    """

    path: str
    type: str
    description: str
    unit: str = ""
    default: Any = None
    default_text: str = ""
    choices: tuple[Any, ...] = ()
    minimum: float | None = None
    minimum_inclusive: bool = True
    maximum: float | None = None
    maximum_inclusive: bool = True
    rule: str = ""
    when: tuple[str, tuple[str, ...]] | None = None
    required_when: tuple[str, tuple[str, ...]] | None = None
    open: bool = False
    removed: Mapping[str, str] = dataclasses.field(default_factory=dict, hash=False)

    @property
    def key(self) -> str:
        return self.path.rsplit(".", 1)[-1]

    @property
    def parent(self) -> str:
        return self.path.rsplit(".", 1)[0] if "." in self.path else ""

    def required(self, siblings: Mapping[str, Any]) -> bool:
        if self.default is REQUIRED:
            return True
        if self.required_when is not None:
            key, values = self.required_when
            return siblings.get(key) in values
        return False

    def range_text(self) -> str:
        lo, hi = self.minimum, self.maximum
        lo_op = "<=" if self.minimum_inclusive else "<"
        hi_op = "<=" if self.maximum_inclusive else "<"
        if lo is not None and hi is not None:
            return f"with {_num(lo)} {lo_op} {self.key} {hi_op} {_num(hi)}"
        if lo is not None:
            return f"{'>=' if self.minimum_inclusive else '>'} {_num(lo)}"
        if hi is not None:
            return f"{hi_op} {_num(hi)}"
        return ""

    def expected(self) -> str:
        """What a valid value is, in words (the end of an error line)."""
        if self.choices:
            if len(self.choices) == 1:
                return _toml(self.choices[0])
            return "one of " + ", ".join(_toml(c) for c in self.choices)
        text = TYPES[self.type].noun
        if self.type == "table":
            text = f"a table [{_table_name(self.path)}]"
        elif self.type == "tables":
            text = f"an array of tables [[{_table_name(self.path)}]]"
        rng = self.range_text()
        if rng:
            text += " " + rng
        if self.unit:
            scalar = self.type in ("number", "number-or-list", "numbers")
            text += f" in {self.unit}" if scalar else f" (values in {self.unit})"
        return text

    def in_range(self, value: float) -> bool:
        if self.minimum is not None and (
            value < self.minimum or (value == self.minimum and not self.minimum_inclusive)
        ):
            return False
        return not (
            self.maximum is not None
            and (value > self.maximum or (value == self.maximum and not self.maximum_inclusive))
        )


@dataclass(frozen=True)
class ExactlyOne:
    """Exactly one of ``keys`` must be given in the table ``table`` (when its sibling
    ``when[0]`` has one of the values ``when[1]``)."""

    table: str
    keys: tuple[str, ...]
    when: tuple[str, tuple[str, ...]] | None = None

    def text(self) -> str:
        words = " or ".join(f"`{k}`" for k in self.keys)
        cond = "" if self.when is None else f" when {_cond(self.when)}"
        return f"`[{_table_name(self.table)}]`: exactly one of {words}{cond}."


def _num(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def _toml(value: Any) -> str:
    """A default or choice as it is written in TOML."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return str(value)


def _table_name(path: str) -> str:
    return path.replace("[]", "")


def _cond(when: tuple[str, tuple[str, ...]]) -> str:
    key, values = when
    return f"{key} = " + " | ".join(_toml(v) for v in values)


# ---- the law parameters come from the core's catalog (vibroimpact.contact.CATALOG) ----


def _law_fields() -> dict[str, dict[str, Any]]:
    """For each law parameter: the kinds that take it and each kind's default."""
    out: dict[str, dict[str, Any]] = {}
    for kind, entry in contact.CATALOG.items():
        for p in entry["parameters"]:
            out.setdefault(p["name"], {})[kind] = p["default"]
    return out


def _kinds_requiring(param: str) -> tuple[str, ...]:
    return tuple(kind for kind, entry in contact.CATALOG.items()
                 if any(p["name"] == param and p["required"] for p in entry["parameters"]))


def _alternatives() -> tuple[tuple[str, tuple[str, ...]], ...]:
    """The laws whose optional parameters (no default, not required) are alternatives, one of
    which must be given (hunt-crossley: restitution or damping)."""
    out = []
    for kind, entry in contact.CATALOG.items():
        optional = tuple(p["name"] for p in entry["parameters"]
                         if not p["required"] and p["default"] is None)
        if optional:
            out.append((kind, optional))
    return tuple(out)


_LAW_FIELDS = _law_fields()
_LAW_KINDS = tuple(contact.LAWS)


def _kinds_with(param: str) -> tuple[str, ...]:
    return tuple(_LAW_FIELDS.get(param, {}))


def _exponent_default() -> str:
    defaults = _LAW_FIELDS.get("exponent", {})
    if not defaults:
        return ""
    common = Counter(defaults.values()).most_common(1)[0][0]
    others = ", ".join(f"{k}: {_num(v)}" for k, v in defaults.items() if v != common)
    return f"{_num(common)}" + (f" ({others})" if others else "")


_RESTITUTION_LAWS = _kinds_requiring("restitution")
_DAMPING_REQUIRED = _kinds_requiring("damping")
_GEOMETRY_KINDS = contact.GEOMETRY_KINDS
_SDOF = ("kind", ("sdof",))
_MATRICES = ("kind", ("matrices",))
_BEAM = ("kind", ("beam",))
_JEFFCOTT = ("kind", ("jeffcott",))
_SPINNING = ("kind", ("jeffcott", "matrices", "beam"))
_RUN_UP = ("spin_profile", ("linear",))
# keys of [[gaps]] and [[loads]] that depend on the structure (see _Checker.context)
_ON_BEAM = ("structure.kind", ("beam",))
_WITHOUT_NODES = ("structure.kind", ("sdof", "jeffcott"))
_WITH_NODES = ("structure.kind", ("beam", "matrices"))
_NODE_NAMES = ("start", "middle", "end")
_DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")

#: Every accepted key of a model file, in the order of the reference.
# fmt: off
def _choices(part: str, name: str) -> tuple[str, ...]:
    """The words the core's field ``name`` of ``part`` takes (:data:`MODEL_CATALOG`)."""
    return tuple(MODEL_CATALOG[part][name]["choices"])


SCHEMA: tuple[Field, ...] = (
    Field("schema_version", "integer", "version of this file format", default=SCHEMA_VERSION,
          choices=(SCHEMA_VERSION,)),
    Field("structure", "table", "the linear structure M x'' + C x' + K x = F (paper eq. 1)",
          default=REQUIRED),
    Field("gaps", "tables", "clearances, one table each (conventions.md §Gaps)", default=[],
          default_text="none"),
    Field("initial", "table", "initial state at t = 0", default={}, default_text="at rest"),
    Field("loads", "tables", "external loads F(t), one table each", default=[],
          default_text="none"),
    Field("solver", "table", "integrator and time span", default=REQUIRED),
    Field("output", "table", "what the run keeps", default={}, default_text="everything"),
    # [structure]
    Field("structure.kind", "string", "single DOF, matrices, a beam (vibroimpact.fe.beam) or a "
          "Jeffcott rotor (DOFs 0 = x, 1 = y; docs/rotors.md)",
          default=REQUIRED, choices=("sdof", "matrices", "beam", "jeffcott")),
    Field("structure.mass", "number", "disc mass", unit="kg", default=REQUIRED, minimum=0,
          minimum_inclusive=False, when=_JEFFCOTT),
    Field("structure.stiffness", "number-or-list", "shaft stiffness to ground in each direction "
          "(one number, or [x, y])", unit="N/m", default=0.0, minimum=0, when=_JEFFCOTT),
    Field("structure.damping", "number-or-list", "damping to ground in each direction (one "
          "number, or [x, y])", unit="N·s/m", default=0.0, minimum=0, when=_JEFFCOTT),
    Field("structure.spin_speed", "number", "spin speed Ω of a rotor (its gyroscopic forces "
          "Ω G x' and unbalance loads turn with it)", unit="rad/s",
          default=model_default("structure", "spin_speed"),
          when=_SPINNING),
    Field("structure.spin_profile", "string", "the spin speed over time: constant, or a "
          "linear run-up (or run-down) from spin_speed to spin_speed_end over run_up_time, "
          "then held (docs/rotors.md)", default=model_default("structure", "spin_profile"),
          choices=_choices("structure", "spin_profile"),
          when=_SPINNING),
    Field("structure.spin_speed_end", "number", "the speed a run-up ends at", unit="rad/s",
          default=None, when=_RUN_UP, required_when=_RUN_UP),
    Field("structure.run_up_time", "number", "the duration of a run-up", unit="s",
          default=None, minimum=0, minimum_inclusive=False, when=_RUN_UP,
          required_when=_RUN_UP),
    Field("structure.gyroscopic", "matrix", "gyroscopic matrix G of a rotor (M x'' + (C + Ω G) "
          "x' + K x = F)", unit="kg·m^2", default_text="none",
          rule="same shape as mass, skew-symmetric", when=_MATRICES),
    Field("structure.mass", "number", "mass", unit="kg", default=REQUIRED, minimum=0,
          minimum_inclusive=False, when=_SDOF),
    Field("structure.stiffness", "number", "spring to ground", unit="N/m", default=0.0,
          minimum=0, when=_SDOF),
    Field("structure.damping", "number", "dashpot to ground", unit="N·s/m", default=0.0,
          minimum=0, when=_SDOF),
    Field("structure.mass", "matrix", "mass matrix M", unit="kg", default=REQUIRED,
          rule="square, symmetric, positive semi-definite: a DOF whose row is zero is massless, "
          "and any null space of M (reduced integration, expanded shells) massless modes, "
          "condensed out (see Massless DOFs)", when=_MATRICES),
    Field("structure.stiffness", "matrix", "stiffness matrix K", unit="N/m",
          default_text="zeros", rule="same shape as mass, symmetric", when=_MATRICES),
    Field("structure.damping", "matrix", "damping matrix C (or a [structure.damping] table)",
          unit="N·s/m", default_text="zeros", rule="same shape as mass, symmetric",
          when=_MATRICES),
    Field("structure.format", "string", "how the matrix files are read: auto by suffix and "
          "content (.npy, .npz; .sti/.mas: calculix; .mtx: mtx if it starts %%MatrixMarket, else "
          "abaqus); mtx: Matrix Market; npz: scipy.sparse.save_npz, or an archive whose array "
          "named mass, stiffness or damping (as the key) is read; calculix: *MATRIX STORAGE; "
          "abaqus: *MATRIX GENERATE",
          default="auto", choices=FORMATS, when=_MATRICES),
    Field("structure.dof_map", "dof-map", "node and direction of every DOF, to address gaps and "
          "loads by node: a .csv file (dof,node,direction rows), a CalculiX .dof file, or a list "
          "of \"node.direction\" labels (\"12.x\", \"12.5\")",
          default_text="from the files: job.dof beside a CalculiX .sti/.mas, the node/DOF entries "
          "of ABAQUS files, dof_nodes/dof_directions of an .npz; else none",
          rule="one entry per DOF", when=_MATRICES),
    Field("structure.dof_units", "strings", "the unit of each DOF's displacement, \"m\" or "
          "\"rad\" (results, files and plots label each DOF with it)",
          default_text="from the DOF map's directions (4-6, rx-rz: rad); without a map all m",
          rule="one entry per DOF; not with a DOF map", when=_MATRICES),
    Field("structure.length", "number", "beam length (the beam lies on z from 0)", unit="m",
          default=REQUIRED, minimum=0, minimum_inclusive=False, when=_BEAM),
    Field("structure.elements", "integer", "number of equal elements", default=REQUIRED,
          minimum=1, maximum=1000, when=_BEAM),
    Field("structure.theory", "string", "beam theory", default="timoshenko",
          choices=("euler-bernoulli", "timoshenko"), when=_BEAM),
    Field("structure.dofs_per_node", "integer", "2: planar bending in x-z (DOFs x, ry); 4: a "
          "rotor's two bending planes (x, y, rx, ry); 6: 3-D (x, y, z, rx, ry, rz)", default=2,
          choices=(2, 4, 6), when=_BEAM),
    Field("structure.lumped_mass", "boolean", "HRZ-lumped instead of consistent mass",
          default=False, when=_BEAM),
    Field("structure.rotary_inertia", "boolean", "include the rotary inertia ρI",
          default_text="true for timoshenko, false for euler-bernoulli", when=_BEAM),
    Field("structure.section", "table", "cross-section", default=REQUIRED, when=_BEAM),
    Field("structure.material", "table", "linear elastic material", default=REQUIRED,
          when=_BEAM),
    Field("structure.supports", "tables", "supports (nodes held to ground)", default=[],
          default_text="none (free-free)", when=_BEAM),
    Field("structure.springs", "tables", "springs to ground", default=[], default_text="none",
          when=_BEAM),
    Field("structure.masses", "tables", "point masses", default=[], default_text="none",
          when=_BEAM),
    Field("structure.discs", "tables", "rotor discs (dofs_per_node = 4 or 6)", default=[],
          default_text="none", when=_BEAM),
    Field("structure.bearings", "tables", "rotor bearings: springs and dampers to ground in x "
          "and y (dofs_per_node = 4 or 6)", default=[], default_text="none", when=_BEAM),
    Field("structure.damping", "table", "damping C built from M and K (matrices: of the model "
          "that runs, massless DOFs and modes condensed)", default_text="none",
          when=("kind", ("beam", "matrices"))),
    # [structure.section]
    Field("structure.section.kind", "string", "shape (Cowper's shear coefficient for circle, "
          "tube, rectangle)", default=REQUIRED, choices=("circle", "tube", "rectangle", "user")),
    Field("structure.section.diameter", "number", "diameter", unit="m", default=REQUIRED,
          minimum=0, minimum_inclusive=False, when=("kind", ("circle",))),
    Field("structure.section.outer_diameter", "number", "outer diameter", unit="m",
          default=REQUIRED, minimum=0, minimum_inclusive=False, when=("kind", ("tube",))),
    Field("structure.section.wall_thickness", "number", "wall thickness", unit="m", minimum=0,
          minimum_inclusive=False, rule="or inner_diameter", when=("kind", ("tube",))),
    Field("structure.section.inner_diameter", "number", "inner diameter", unit="m", minimum=0,
          rule="or wall_thickness", when=("kind", ("tube",))),
    Field("structure.section.size_x", "number", "width along x (the planar deflection)",
          unit="m", default=REQUIRED, minimum=0, minimum_inclusive=False,
          when=("kind", ("rectangle",))),
    Field("structure.section.size_y", "number", "width along y", unit="m", default=REQUIRED,
          minimum=0, minimum_inclusive=False, when=("kind", ("rectangle",))),
    Field("structure.section.area", "number", "area A", unit="m^2", default=REQUIRED, minimum=0,
          minimum_inclusive=False, when=("kind", ("user",))),
    Field("structure.section.second_moment", "number", "second moment ∫x² dA (and ∫y² dA unless "
          "second_moment_y)", unit="m^4", default=REQUIRED, minimum=0, minimum_inclusive=False,
          when=("kind", ("user",))),
    Field("structure.section.second_moment_y", "number", "second moment ∫y² dA", unit="m^4",
          default_text="second_moment", minimum=0, minimum_inclusive=False,
          when=("kind", ("user",))),
    Field("structure.section.torsion_constant", "number", "torsion constant J", unit="m^4",
          minimum=0, minimum_inclusive=False, rule="required for dofs_per_node = 6",
          when=("kind", ("user",))),
    Field("structure.section.shear_coefficient", "number", "Timoshenko shear coefficient κ",
          default_text="Cowper's formula for the shape", minimum=0, minimum_inclusive=False,
          maximum=2, rule="required for a user section with theory = \"timoshenko\""),
    # [structure.material]
    Field("structure.material.youngs_modulus", "number", "Young's modulus E", unit="Pa",
          default=REQUIRED, minimum=0, minimum_inclusive=False),
    Field("structure.material.poisson", "number", "Poisson's ratio ν (G = E / 2(1 + ν))",
          default=REQUIRED, minimum=-1, minimum_inclusive=False, maximum=0.5,
          maximum_inclusive=False),
    Field("structure.material.density", "number", "density ρ", unit="kg/m^3", default=REQUIRED,
          minimum=0, minimum_inclusive=False),
    # [[structure.supports]], [[structure.springs]], [[structure.masses]]
    Field("structure.supports[].node", "node", "the node", rule="or at"),
    Field("structure.supports[].at", "number", "the node at this fraction of the length",
          minimum=0, maximum=1, rule="or node"),
    Field("structure.supports[].kind", "string", "fixed: every DOF; pinned: the translations",
          default="fixed", choices=("fixed", "pinned", "free")),
    Field("structure.supports[].directions", "strings", "the DOFs to fix instead of kind "
          "(\"x\", \"ry\", ...)", default_text="from kind"),
    Field("structure.springs[].node", "node", "the node", rule="or at"),
    Field("structure.springs[].at", "number", "the node at this fraction of the length",
          minimum=0, maximum=1, rule="or node"),
    Field("structure.springs[].direction", "string", "the DOF", default="x", choices=_DIRECTIONS),
    Field("structure.springs[].stiffness", "number", "stiffness to ground",
          unit="N/m or N·m/rad", default=REQUIRED, minimum=0),
    Field("structure.masses[].node", "node", "the node", rule="or at"),
    Field("structure.masses[].at", "number", "the node at this fraction of the length",
          minimum=0, maximum=1, rule="or node"),
    Field("structure.masses[].mass", "number", "mass on each translation", unit="kg",
          default=REQUIRED, minimum=0),
    Field("structure.masses[].rotary_inertia", "number", "inertia on each rotation",
          unit="kg·m^2", default=0.0, minimum=0),
    # [[structure.discs]], [[structure.bearings]] (rotors)
    Field("structure.discs[].node", "node", "the node", rule="or at"),
    Field("structure.discs[].at", "number", "the node at this fraction of the length",
          minimum=0, maximum=1, rule="or node"),
    Field("structure.discs[].mass", "number", "mass on x and y", unit="kg", default=REQUIRED,
          minimum=0),
    Field("structure.discs[].polar_inertia", "number", "polar moment of inertia I_p (its "
          "gyroscopic couple Ω I_p)", unit="kg·m^2", default=0.0, minimum=0),
    Field("structure.discs[].diametral_inertia", "number", "diametral moment of inertia I_d "
          "(on rx and ry)", unit="kg·m^2", default=0.0, minimum=0),
    Field("structure.bearings[].node", "node", "the node", rule="or at"),
    Field("structure.bearings[].at", "number", "the node at this fraction of the length",
          minimum=0, maximum=1, rule="or node"),
    *(Field(f"structure.bearings[].{key}", "number", f"{what} in {d}", unit=unit, default=0.0,
            minimum=0)
      for key, what, d, unit in (("kxx", "stiffness", "x", "N/m"), ("kyy", "stiffness", "y", "N/m"),
                                 ("cxx", "damping", "x", "N·s/m"),
                                 ("cyy", "damping", "y", "N·s/m"))),
    # [structure.damping] (beams, matrices)
    Field("structure.damping.kind", "string", "rayleigh: C = alpha M + beta K; modal: a ratio "
          "per mode", default=REQUIRED, choices=("rayleigh", "modal")),
    Field("structure.damping.alpha", "number", "mass coefficient α", unit="1/s", minimum=0,
          rule="with beta, or give frequencies and ratios", when=("kind", ("rayleigh",))),
    Field("structure.damping.beta", "number", "stiffness coefficient β", unit="s", minimum=0,
          rule="with alpha, or give frequencies and ratios", when=("kind", ("rayleigh",))),
    Field("structure.damping.frequencies", "numbers", "two frequencies f1, f2 for the ratios",
          unit="Hz", rule="rayleigh: two, with ratios", when=("kind", ("rayleigh",))),
    Field("structure.damping.ratios", "numbers", "damping ratios ζ", rule="rayleigh: two, at "
          "frequencies; modal: per elastic mode, the last repeats",
          required_when=("kind", ("modal",))),
    # [[gaps]]
    Field("gaps[].kind", "string", "linear: a wall on the gap coordinate u (conventions.md §Gaps); "
          "radial: a circular stator around the DOFs [x, y] of a rotor (rotors.md §Radial gaps)",
          default="linear", choices=("linear", "radial")),
    Field("gaps[].dof", "dofs", "DOF(s) of the gap coordinate u = Σ coefficients[i]·x[dof[i]] "
          "(radial: [ix, iy])", required_when=_WITHOUT_NODES,
          rule="0 <= dof < number of DOFs; beam, matrices: or node"),
    Field("gaps[].node", "node", "the node of the gap (beam: index or name; matrices: node "
          "label of the DOF map)", rule="or dof (beam: or at)", when=_WITH_NODES),
    Field("gaps[].at", "number", "the beam node at this fraction of the length", minimum=0,
          maximum=1, rule="or dof or node; must fall on a node", when=_ON_BEAM),
    Field("gaps[].direction", "string", "the DOF at that node", default="x",
          choices=_DIRECTIONS, when=_WITH_NODES),
    Field("gaps[].directions", "strings", "radial, on a beam or matrices: the directions of "
          "the rotor's x and y at node", default_text='["x", "y"]', rule="two, with node",
          when=("kind", ("radial",))),
    Field("gaps[].coefficients", "numbers", "weights of the DOFs in u ([1, -1]: x[i] - x[j])",
          default_text="1 per DOF", rule="one per dof, not all zero", when=("kind", ("linear",))),
    Field("gaps[].clearance", "number", "distance to the wall(s) (radial: the radial clearance c, "
          "δ = |(x − x_s, y − y_s)| − c)", unit="m", default=model_default("gap", "clearance"),
          minimum=0),
    Field("gaps[].side", "string", "wall at u = +clearance, at u = -clearance, or both",
          default=model_default("gap", "side"), choices=_choices("gap", "side"),
          when=("kind", ("linear",))),
    Field("gaps[].center", "numbers", "stator centre [x_s, y_s]", unit="m",
          default=list(model_default("radial-gap", "center")),
          rule="two", when=("kind", ("radial",))),
    Field("gaps[].friction", "number", "Coulomb coefficient μ of the rub (F_T = μ F_N against "
          "the sliding speed v_rel = R Ω + ρ θ')", default=model_default("radial-gap", "friction"),
          minimum=0,
          when=("kind", ("radial",))),
    Field("gaps[].radius", "number", "the rotor's radius R at the contact", unit="m", minimum=0,
          minimum_inclusive=False, rule="required when friction > 0", when=("kind", ("radial",))),
    Field("gaps[].friction_law", "string", "coulomb: F_T = μ F_N sign(v_rel), the run stops "
          "where v_rel crosses 0 in contact (sticking is not modelled); regularised: "
          "F_T = μ F_N tanh(v_rel / regularisation_speed)",
          default=model_default("radial-gap", "friction_law"),
          choices=_choices("radial-gap", "friction_law"), when=("kind", ("radial",))),
    Field("gaps[].regularisation_speed", "number", "the speed v_reg of the regularised friction",
          unit="m/s", minimum=0, minimum_inclusive=False,
          rule="required for friction_law = \"regularised\"", when=("kind", ("radial",))),
    Field("gaps[].name", "string", "label in results"),
    Field("gaps[].law", "table", "contact-force law (contact-laws.md)", default=REQUIRED),
    # [gaps.law]
    Field("gaps[].law.kind", "string", "contact-force law (vibroimpact.contact)",
          default=REQUIRED, choices=_LAW_KINDS, removed=contact.REMOVED_LAWS),
    Field("gaps[].law.stiffness", "number", "contact stiffness K", unit="N/m^n", minimum=0,
          minimum_inclusive=False, rule="or give geometry",
          when=("kind", _kinds_with("stiffness"))),
    Field("gaps[].law.geometry", "table", "compute K from shape and material (paper eq. 4)",
          rule="or give stiffness", when=("kind", _kinds_with("stiffness"))),
    Field("gaps[].law.exponent", "number", "exponent n of the penetration δⁿ", minimum=1,
          default_text=_exponent_default(), rule="1 for kelvin-voigt",
          when=("kind", _kinds_with("exponent"))),
    Field("gaps[].law.compliance", "number", "a linear spring in series with the law (a "
          "flexible stop; set by the condensation on a node with a massless part)",
          unit="m/N", minimum=0, default=contact.catalog_default("hertz", "compliance"),
          when=("kind", _kinds_with("compliance"))),
    # the range of every kind's restitution (rigid's takes 0, a plastic impact); each kind's own
    # is checked by its class, which asks the core
    Field("gaps[].law.restitution", "number", "coefficient of restitution ce", minimum=0,
          maximum=1, rule="0 < restitution but for rigid",
          when=("kind", _kinds_with("restitution")),
          required_when=("kind", _RESTITUTION_LAWS)),
    Field("gaps[].law.damping", "number", "damping (hunt-crossley: b in N·s/m^(n+1))",
          unit="N·s/m", minimum=0, when=("kind", _kinds_with("damping")),
          required_when=("kind", _DAMPING_REQUIRED)),
    Field("gaps[].law.loading_penetration", "numbers", "tabulated loading curve: penetrations "
          "δ, from 0, increasing", unit="m", default=REQUIRED,
          when=("kind", _kinds_with("loading_penetration"))),
    Field("gaps[].law.loading_force", "numbers", "tabulated loading curve: forces, from 0, "
          "one per penetration", unit="N", default=REQUIRED,
          when=("kind", _kinds_with("loading_force"))),
    Field("gaps[].law.unloading_penetration", "numbers", "tabulated unloading curve: "
          "penetrations δ, from 0, increasing", unit="m", default=REQUIRED,
          when=("kind", _kinds_with("unloading_penetration"))),
    Field("gaps[].law.unloading_force", "numbers", "tabulated unloading curve: forces, from 0, "
          "on or below the loading curve", unit="N", default=REQUIRED,
          when=("kind", _kinds_with("unloading_force"))),
    Field("gaps[].law.reversal_band", "number", "tabulated: speed band over which the force "
          "passes from loading to unloading, as a fraction of v_imp",
          default=contact.catalog_default("tabulated", "reversal_band"), minimum=0,
          minimum_inclusive=False, maximum=1, when=("kind", _kinds_with("reversal_band"))),
    # [gaps.law.geometry]
    Field("gaps[].law.geometry.kind", "string", "the two bodies (paper eq. 4)",
          default=REQUIRED, choices=_GEOMETRY_KINDS),
    Field("gaps[].law.geometry.radius1", "number", "radius of body 1 (the ball, pin or punch)",
          unit="m", default=REQUIRED, minimum=0, minimum_inclusive=False),
    Field("gaps[].law.geometry.radius2", "number", "radius of body 2 (the socket, sphere or "
          "hole)", unit="m", default=REQUIRED, minimum=0, minimum_inclusive=False,
          rule="differs from radius1 for ball-in-socket; > radius1 for cylinder-in-hole",
          when=("kind", ("sphere-sphere", "ball-in-socket", "cylinder-in-hole"))),
    Field("gaps[].law.geometry.length", "number", "contact length of the pin in the hole",
          unit="m", default=REQUIRED, minimum=0, minimum_inclusive=False,
          when=("kind", ("cylinder-in-hole",))),
    Field("gaps[].law.geometry.load", "number", "reference force at which Johnson's relation "
          "is linearised (law exponent 1)", unit="N", default=REQUIRED, minimum=0,
          minimum_inclusive=False, when=("kind", ("cylinder-in-hole",))),
    Field("gaps[].law.geometry.youngs_modulus", "number", "Young's modulus of body 1",
          unit="Pa", default=REQUIRED, minimum=0, minimum_inclusive=False),
    Field("gaps[].law.geometry.poisson", "number", "Poisson's ratio of body 1",
          default=REQUIRED, minimum=-1, minimum_inclusive=False, maximum=0.5,
          maximum_inclusive=False),
    Field("gaps[].law.geometry.youngs_modulus2", "number", "Young's modulus of body 2",
          unit="Pa", default_text="youngs_modulus", minimum=0, minimum_inclusive=False),
    Field("gaps[].law.geometry.poisson2", "number", "Poisson's ratio of body 2",
          default_text="poisson", minimum=-1, minimum_inclusive=False, maximum=0.5,
          maximum_inclusive=False),
    # [initial]
    Field("initial.displacement", "number-or-list", "x(0): a number for one DOF, a list for "
          "several", unit="m", default_text="zeros", rule="one per DOF"),
    Field("initial.velocity", "number-or-list", "x'(0): a number for one DOF, a list for "
          "several", unit="m/s", default_text="zeros", rule="one per DOF"),
    # [[loads]]
    Field("loads[].kind", "string", "constant F = amplitude; harmonic F = amplitude·sin(2π·"
          "frequency·t + phase); table F = scale·F(t) from a CSV file; unbalance F = magnitude·"
          "Ω²·(cos(Ωt + phase), sin(Ωt + phase)) on [x, y] at structure.spin_speed Ω",
          default=REQUIRED, choices=tuple(
              part.split(".", 1)[1] for part in MODEL_CATALOG if part.startswith("load."))),
    Field("loads[].dof", "dofs", "DOF(s) the force acts on (the same force on each)",
          required_when=_WITHOUT_NODES, rule="0 <= dof < number of DOFs; beam, matrices: or nodes"),
    Field("loads[].nodes", "nodes", "the nodes the force acts on (the same force on each; "
          "matrices: node labels of the DOF map, \"all\": every node with that direction)",
          rule="or dof", when=_WITH_NODES),
    Field("loads[].direction", "string", "the DOF at those nodes", default="x",
          choices=_DIRECTIONS, when=_WITH_NODES),
    Field("loads[].amplitude", "number", "force amplitude", unit="N", default=REQUIRED,
          when=("kind", ("constant", "harmonic"))),
    Field("loads[].frequency", "number", "frequency f", unit="Hz", default=REQUIRED, minimum=0,
          when=("kind", ("harmonic",))),
    Field("loads[].phase", "number", "phase φ", unit="rad",
          default=model_default("load.harmonic", "phase"),
          when=("kind", ("harmonic", "unbalance"))),
    Field("loads[].magnitude", "number", "unbalance m·e (mass times eccentricity)", unit="kg·m",
          default=REQUIRED, minimum=0, when=("kind", ("unbalance",))),
    Field("loads[].node", "node", "the node whose x and y the unbalance acts on (beam: index "
          "or name; matrices: node label of the DOF map)", rule="or dof = [ix, iy]",
          when=("kind", ("unbalance",))),
    Field("loads[].file", "csv", "CSV: time [s], force [N] per line (optional header line); "
          "path relative to the model file", default=REQUIRED,
          rule="times strictly increasing, at least 2 rows", when=("kind", ("table",))),
    Field("loads[].scale", "number", "factor applied to the tabulated force",
          default=model_default("load.table", "scale"),
          when=("kind", ("table",))),
    # [solver]
    Field("solver.method", "string", "integrator (see Solver methods below); its options go "
          "in [solver] too", default="newmark"),
    Field("solver.dt", "number", "time step", unit="s", default=REQUIRED, minimum=0,
          minimum_inclusive=False, rule="dt <= t_end"),
    Field("solver.t_end", "number", "end time (the run starts at t = 0)", unit="s",
          default=REQUIRED, minimum=0, minimum_inclusive=False),
    # [output]
    Field("output.every", "integer", "keep every k-th step in the time histories (impacts, "
          "peaks and energies see every step)", default=1, minimum=1),
    Field("output.dofs", "dof-list", "DOFs whose histories are kept (massless ones are "
          "recovered, see Massless DOFs)", default_text="all",
          rule="distinct, 0 <= dof < number of DOFs; or nodes"),
    Field("output.nodes", "nodes", "nodes whose DOFs' histories are kept (beam: index or name; "
          "matrices: node labels of the DOF map, every layer of an expanded shell node)",
          rule="or dofs", when=_WITH_NODES),
    Field("output.directions", "strings", "the directions kept at those nodes",
          default_text="every direction of each node", rule=f"of {', '.join(_DIRECTIONS)}; "
          "with nodes", when=_WITH_NODES),
)
# fmt: on

# A parameter that a law class takes but the table above does not list is still accepted (as
# a number), so that a new law in vibroimpact.contact works in model files at once.
SCHEMA = SCHEMA + tuple(
    Field(
        f"gaps[].law.{name}",
        "number",
        f"parameter of the {', '.join(kinds)} law",
        when=("kind", tuple(kinds)),
    )
    for name, kinds in _LAW_FIELDS.items()
    if not any(f.path == f"gaps[].law.{name}" for f in SCHEMA)
)

_OPEN_TABLES = {"solver"}
SCHEMA = tuple(dataclasses.replace(f, open=True) if f.path in _OPEN_TABLES else f for f in SCHEMA)

#: Constraints between keys.
RULES: tuple[ExactlyOne, ...] = (
    ExactlyOne("gaps[].law", ("stiffness", "geometry"), when=("kind", _kinds_with("stiffness"))),
    *(ExactlyOne("gaps[].law", params, when=("kind", (kind,))) for kind, params in _alternatives()),
    ExactlyOne("structure.section", ("wall_thickness", "inner_diameter"),
               when=("kind", ("tube",))),
    ExactlyOne("structure.supports[]", ("node", "at")),
    ExactlyOne("structure.springs[]", ("node", "at")),
    ExactlyOne("structure.masses[]", ("node", "at")),
    ExactlyOne("structure.discs[]", ("node", "at")),
    ExactlyOne("structure.bearings[]", ("node", "at")),
)


def _children() -> dict[str, tuple[Field, ...]]:
    out: dict[str, list[Field]] = {}
    for f in SCHEMA:
        out.setdefault(f.parent, []).append(f)
    return {k: tuple(v) for k, v in out.items()}


_CHILDREN = _children()


def _table_keys() -> dict[str, frozenset[str]]:
    """The keys of every table of the schema, by its path (``gaps[]``, ``gaps[].law``); the
    open ``[solver]`` also takes every method's options."""
    options = {k for m in integrators.METHODS for k in integrators.method_options(m)}
    out: dict[str, frozenset[str]] = {}
    for f in SCHEMA:
        if f.type in ("table", "tables"):
            path = f.path + "[]" * (f.type == "tables")
            keys = {c.key for c in _CHILDREN.get(path, ())} | (options if f.open else set())
            out[path] = frozenset(keys)
    return out


_TABLE_KEYS = _table_keys()


# --------------------------------------------------------------------------------------------
# Value types
# --------------------------------------------------------------------------------------------


class _Invalid(Exception):
    """A value does not fit its field. ``expected`` replaces the field's own description;
    ``shown`` replaces the value's repr."""

    def __init__(self, expected: str | None = None, shown: str | None = None) -> None:
        super().__init__(expected)
        self.expected = expected
        self.shown = shown


@dataclass(frozen=True)
class _Type:
    name: str  # in the reference
    noun: str  # in "expected ..."
    convert: Callable[[Any, _Checker], Any]


def _as_number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _Invalid()
    try:
        x = float(value)
    except OverflowError:
        raise _Invalid() from None
    if not math.isfinite(x):
        raise _Invalid()
    return x


_INT64 = 2**63  # TOML integers are 64-bit


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and -_INT64 <= value < _INT64


def _is_index(value: Any) -> bool:
    return _is_int(value) and value >= 0


def _conv_number(value: Any, ck: _Checker) -> float:
    return _as_number(value)


def _conv_integer(value: Any, ck: _Checker) -> int:
    if not _is_int(value):
        raise _Invalid()
    return int(value)


def _conv_string(value: Any, ck: _Checker) -> str:
    if not isinstance(value, str):
        raise _Invalid()
    return value


def _conv_dofs(value: Any, ck: _Checker) -> tuple[int, ...]:
    items = value if isinstance(value, list) else [value]
    if not items or not all(_is_index(d) for d in items):
        raise _Invalid()
    return tuple(items)


def _conv_dof_list(value: Any, ck: _Checker) -> tuple[int, ...]:
    if not isinstance(value, list) or not value or not all(_is_index(d) for d in value):
        raise _Invalid()
    if len(set(value)) != len(value):
        raise _Invalid("a list of distinct DOF indices")
    return tuple(value)


def _conv_numbers(value: Any, ck: _Checker) -> tuple[float, ...]:
    if not isinstance(value, list) or not value:
        raise _Invalid()
    return tuple(_as_number(v) for v in value)


def _conv_number_or_list(value: Any, ck: _Checker) -> tuple[float, ...]:
    if isinstance(value, list):
        if not value:
            raise _Invalid()
        return tuple(_as_number(v) for v in value)
    return (_as_number(value),)


def _conv_matrix(value: Any, ck: _Checker) -> _Matrix:
    if isinstance(value, str):  # read with the others (format, DOF map) by _build_structure
        return _Matrix(ck.file(value, SUFFIXES), repr(value))
    if isinstance(value, list):
        shown = _show(value)
        if not value or not all(isinstance(r, list) for r in value):
            raise _Invalid()
        if len({len(r) for r in value}) != 1:
            raise _Invalid("rows of equal length (an n x n array of arrays)")
        try:
            a = np.array([[_as_number(x) for x in r] for r in value], dtype=float)
        except _Invalid:
            raise _Invalid("finite numbers in every row") from None
    else:
        raise _Invalid()
    if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
        raise _Invalid(f"a square matrix; got shape {a.shape}", shown)
    if not np.all(np.isfinite(a)):
        raise _Invalid("finite values (no NaN or infinity)", shown)
    return _Matrix(a, shown)


def _conv_dof_map(value: Any, ck: _Checker) -> DofMap:
    if isinstance(value, str):
        source: Any = ck.file(value, (".csv", ".dof"))
    elif isinstance(value, list) and value and all(isinstance(v, str) for v in value):
        source = value
    else:
        raise _Invalid()
    try:
        return read_dof_map(source)
    except _CAUGHT as e:
        raise _Invalid(f"a valid DOF map ({_one_line(e)})", repr(value)[:60]) from None


def _conv_csv(value: Any, ck: _Checker) -> _Table:
    if not isinstance(value, str):
        raise _Invalid()
    path = ck.file(value, (".csv",))
    shown = repr(value)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as e:
        raise _Invalid(f"a readable UTF-8 CSV file ({type(e).__name__})", shown) from None
    times: list[float] = []
    forces: list[float] = []
    first = True
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = [p.strip() for p in (s.split(",") if "," in s else s.split())]
        try:
            if len(parts) != 2:
                raise ValueError
            t, f = float(parts[0]), float(parts[1])
        except ValueError:
            if first:  # a header line
                first = False
                continue
            raise _Invalid(
                "two numbers per line: time [s], force [N]", f"{shown} line {lineno} ({s[:40]!r})"
            ) from None
        first = False
        if not (math.isfinite(t) and math.isfinite(f)):
            raise _Invalid("finite numbers", f"{shown} line {lineno} ({s[:40]!r})")
        if times and t <= times[-1]:
            raise _Invalid(
                "strictly increasing times in s",
                f"{shown} line {lineno} (time {t!r} after {times[-1]!r})",
            )
        times.append(t)
        forces.append(f)
    if len(times) < 2:
        rows = f"{len(times)} row{'s' * (len(times) != 1)}"
        raise _Invalid("at least 2 rows: time [s], force [N]", f"{shown} ({rows})")
    return _Table(tuple(times), tuple(forces))


def _conv_boolean(value: Any, ck: _Checker) -> bool:
    if not isinstance(value, bool):
        raise _Invalid()
    return value


def _conv_node(value: Any, ck: _Checker) -> int | str:
    if _is_index(value) or (isinstance(value, str) and value in _NODE_NAMES):
        return value  # type: ignore[no-any-return]
    raise _Invalid()


def _conv_nodes(value: Any, ck: _Checker) -> str | tuple[int | str, ...]:
    if isinstance(value, str) and value == "all":
        return value
    items = value if isinstance(value, list) else [value]
    if not items:
        raise _Invalid()
    return tuple(_conv_node(v, ck) for v in items)


def _conv_strings(value: Any, ck: _Checker) -> tuple[str, ...]:
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise _Invalid()
    return tuple(value)


def _conv_table(value: Any, ck: _Checker) -> Any:  # handled by the walker
    raise NotImplementedError


@dataclass(frozen=True)
class _Matrix:
    """An inline matrix (an array) or a matrix file (its path), and how errors show it."""

    source: NDArray[np.float64] | Path
    shown: str


@dataclass(frozen=True)
class _Table:
    time: tuple[float, ...]
    force: tuple[float, ...]


#: The value types of :data:`SCHEMA`.
TYPES: dict[str, _Type] = {
    "number": _Type("number", "a number", _conv_number),
    "integer": _Type("integer", "an integer", _conv_integer),
    "string": _Type("string", "a string", _conv_string),
    "dofs": _Type(
        "DOF index or list", "a DOF index (integer >= 0) or a non-empty list of them", _conv_dofs
    ),
    "dof-list": _Type(
        "list of DOF indices", "a non-empty list of DOF indices (integers >= 0)", _conv_dof_list
    ),
    "numbers": _Type("list of numbers", "a non-empty list of numbers", _conv_numbers),
    "number-or-list": _Type(
        "number or list", "a number or a non-empty list of numbers", _conv_number_or_list
    ),
    "matrix": _Type(
        "matrix or file",
        "an n x n array of arrays of numbers, or the path of a matrix file ("
        + ", ".join(SUFFIXES) + ")",
        _conv_matrix,
    ),
    "dof-map": _Type(
        "file path or list of strings",
        'the path of a .csv or .dof file, or a non-empty list of "node.direction" labels',
        _conv_dof_map,
    ),
    "csv": _Type("file path", "the path of a .csv file", _conv_csv),
    "table": _Type("table", "a table", _conv_table),
    "tables": _Type("array of tables", "an array of tables", _conv_table),
    "boolean": _Type("boolean", "true or false", _conv_boolean),
    "node": _Type("node", 'a node index (integer >= 0) or "start", "middle", "end"', _conv_node),
    "nodes": _Type(
        "node set", '"all", a node (index or "start", "middle", "end") or a list of nodes',
        _conv_nodes,
    ),
    "strings": _Type("list of strings", "a non-empty list of strings", _conv_strings),
}


# --------------------------------------------------------------------------------------------
# Checking a document
# --------------------------------------------------------------------------------------------

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
_EXTRA = "\0extra"  # a table's keys passed through (open tables)


def _show(value: Any) -> str:
    """A value's repr, kept short and on one line."""
    r = repr(value)
    return r if len(r) <= 60 else r[:56] + " ..."


def _join(path: str, key: str) -> str:
    if not _BARE_KEY.fullmatch(key):
        key = '"' + key.encode("unicode_escape").decode("ascii").replace('"', '\\"') + '"'
    return f"{path}.{key}" if path else key


def _one_line(message: Any) -> str:
    return " ".join(str(message).split())


def _reprefix(message: Any, mapping: Mapping[str, str], context: str) -> str:
    """Rewrite the field name that starts a dataclass' message (``law.restitution: ...``) as
    the TOML path (``gaps[0].law.restitution: ...``)."""
    msg = _one_line(message)
    for old in sorted(mapping, key=len, reverse=True):
        if msg == old or (msg.startswith(old) and msg[len(old)] in ".: "):
            return mapping[old] + msg[len(old) :]
    if msg.startswith(context) and msg[len(context) : len(context) + 1] in (".", ":", "["):
        return msg
    return f"{context}: {msg}"


class _Checker:
    """Walks a parsed document against :data:`SCHEMA`, collecting one line per mistake."""

    def __init__(self, base: Path) -> None:
        self.base = base
        self.errors: list[tuple[str, str]] = []  # (path, line)
        self.raw: dict[str, Any] = {}
        # values outside the table being checked that decide which keys apply
        # ("structure.kind" for [[gaps]] and [[loads]]) and the beam once built ("beam")
        self.context: dict[str, Any] = {}
        # the data paths of tables reported as having lost their header (not also missing)
        self.headerless: set[str] = set()

    # ---- recording ----

    def add(self, path: str, line: str) -> None:
        self.errors.append((path, line))

    def invalid(self, path: str, value: Any, expected: str, shown: str | None = None) -> None:
        self.add(path, f"{path}: {shown or _show(value)} is not valid; expected {expected}")

    def missing(self, path: str, expected: str) -> None:
        self.add(path, f"{path}: missing; expected {expected}")

    def unknown(self, path: str, key: str, candidates: Sequence[str]) -> None:
        close = difflib.get_close_matches(key, list(candidates), n=1)
        hint = f"did you mean '{close[0]}'? " if close else ""
        known = ", ".join(candidates) if candidates else "no keys here"
        self.add(path, f"{path}: unknown key; {hint}expected one of: {known}")

    def unknown_keys(self, spath: str, dpath: str, unknown: Mapping[str, Sequence[str]],
                     doc: Mapping[str, Any]) -> None:
        """Report the keys ``unknown`` (key -> the keys expected instead) of the table at
        ``dpath`` (schema table ``spath``, its keys ``doc``). When several of them are the
        keys of another table (the one with most of them first), one line says that they
        belong there and that its header is missing, instead of a line each."""
        left = dict(unknown)
        while len(left) >= 2:
            table, keys = max(_TABLE_KEYS.items(), key=lambda t: len(t[1] & left.keys()))
            hit = [k for k in left if k in keys]
            if len(hit) < 2:
                break
            name = _table_name(table.removesuffix("[]"))
            header = f"[[{name}]]" if table.endswith("[]") else f"[{name}]"
            parent, _, key = table.removesuffix("[]").rpartition(".")
            if parent.removesuffix("[]") == spath.removesuffix("[]"):  # a table of this one
                where = _join(dpath, key)
                question = "is its header missing?" if key not in doc else (
                    "are they above its header?")
                self.headerless.add(where)
            else:  # another table's keys, after the header of this one
                where, question = dpath, "is its header missing?"
                if not parent:
                    self.headerless.add(key)
            self.add(where or name, f"{where or name}: {', '.join(hit)} belong in {header}: "
                     f"{question} expected them under the header {header}")
            for k in hit:
                del left[k]
        for key, candidates in left.items():
            self.unknown(_join(dpath, key), key, candidates)

    def lines(self) -> list[str]:
        """The error lines, by table in the order of the reference, then as found."""
        order = [f.key for f in _CHILDREN[""]]

        def rank(item: tuple[str, str]) -> int:
            top = re.split(r"[.\[]", item[0], maxsplit=1)[0]
            return order.index(top) if top in order else -1

        return [line for _, line in sorted(self.errors, key=rank)]

    def ok(self, path: str) -> bool:
        """No mistake at ``path`` or below it."""
        return not any(
            p == path or p.startswith(path + ".") or p.startswith(path + "[")
            for p, _ in self.errors
        )

    def file(self, value: str, suffixes: tuple[str, ...]) -> Path:
        """An existing file with one of ``suffixes``, relative to the model file's folder."""
        shown = repr(value)
        words = " or ".join(suffixes)
        if not value:
            raise _Invalid(f"the path of a {words} file")
        try:
            path = Path(os.path.expanduser(value))
            path = path if path.is_absolute() else self.base / path
            exists = path.is_file()
        except (OSError, ValueError):
            raise _Invalid(f"the path of a {words} file", shown) from None
        if path.suffix.lower() not in suffixes:
            raise _Invalid(f"the path of a {words} file", shown)
        if not exists:
            raise _Invalid(f"an existing {words} file (looked for {str(path)!r})", shown)
        return path

    # ---- the walk ----

    def table(self, spath: str, dpath: str, doc: Mapping[str, Any]) -> dict[str, Any]:
        """Check one table's keys; returns the converted values (defaults filled in)."""
        rows = _CHILDREN.get(spath, ())
        by_key: dict[str, list[Field]] = {}
        for r in rows:
            by_key.setdefault(r.key, []).append(r)
        out: dict[str, Any] = {}
        deciders = [r.key for r in rows if r.when is None and r.key in _deciders(rows)]
        # a law's kind under [[gaps]]: a [gaps.law] key above its (missing) header
        law_kind = spath == "gaps[]" and "law" not in doc and doc.get("kind") in contact.LAWS
        for key in deciders:  # e.g. `kind`: decides which other keys apply
            default = by_key[key][0].default
            if key in doc and not (law_kind and key == "kind"):
                self.value(by_key[key][0], _join(dpath, key), doc[key], out)
            elif default is not None and default is not REQUIRED:
                out[key] = default  # gaps[].kind = "linear"

        def applies(r: Field) -> bool | None:  # None: cannot tell (the decider is bad)
            if r.when is None:
                return True
            key, values = r.when
            known = out if key in out else self.context
            return None if key not in known else known[key] in values

        unknown: dict[str, list[str]] = {}
        for key, value in doc.items():
            if law_kind and key == "kind":
                unknown[key] = []
                continue
            if key in deciders:
                continue
            p = _join(dpath, key)
            named = by_key.get(key)
            if not named:
                if any(r.open for r in _FIELDS_BY_PATH.get(spath, ())):
                    out.setdefault(_EXTRA, {})[key] = value
                    continue
                unknown[key] = list(dict.fromkeys(r.key for r in rows if applies(r) is not False))
                continue
            fits = [r for r in named if applies(r)]
            # one key, two types (structure.damping: a matrix or a table): the table if a table
            fits.sort(key=lambda r: (r.type == "table") != isinstance(value, dict))
            if fits:
                self.value(fits[0], p, value, out)
            elif not any(applies(r) is None for r in named):
                decider, _ = named[0].when or ("", ())
                values = tuple(dict.fromkeys(v for r in named for v in (r.when or ("", ()))[1]))
                self.invalid(
                    p,
                    value,
                    f"no {key} when {decider} = {_toml({**self.context, **out}[decider])} "
                    f"(it applies to {_cond((decider, values))})",
                )
        self.unknown_keys(spath, dpath, unknown, doc)
        for r in rows:
            if r.key in doc or r.key in out or not applies(r):
                continue
            p = _join(dpath, r.key)
            if p in self.headerless:
                continue
            if r.required({**self.context, **out}):
                what = r.expected()
                if r.type == "table":
                    what = f"a table [{_table_name(r.path)}]"
                self.missing(p, what)
            elif r.type == "table" and r.default == {}:
                out[r.key] = self.table(r.path, p, {})
            elif r.default is not None and r.default is not REQUIRED:
                out[r.key] = r.default
        for rule in RULES:
            if rule.table == spath:
                self.rule(rule, dpath, doc, out)
        return out

    def value(self, r: Field, p: str, value: Any, out: dict[str, Any]) -> None:
        self.raw[p] = value
        if r.type == "table":
            if not isinstance(value, dict):
                self.invalid(p, value, r.expected())
                return
            out[r.key] = self.table(r.path, p, value)
            return
        if r.type == "tables":
            if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
                self.invalid(p, value, r.expected())
                return
            out[r.key] = [self.table(r.path + "[]", f"{p}[{i}]", v) for i, v in enumerate(value)]
            return
        try:
            converted = TYPES[r.type].convert(value, self)
        except _Invalid as e:
            self.invalid(p, value, e.expected or r.expected(), e.shown)
            return
        if r.choices and converted not in r.choices:
            if converted in r.removed:
                self.add(p, f"{p}: {r.removed[converted]}")
            else:
                self.invalid(p, value, r.expected())
            return
        if isinstance(converted, (int, float)) and not r.in_range(converted):
            self.invalid(p, value, r.expected())
            return
        out[r.key] = converted

    def rule(
        self, rule: ExactlyOne, dpath: str, doc: Mapping[str, Any], out: Mapping[str, Any]
    ) -> None:
        if rule.when is not None:
            key, values = rule.when
            if out.get(key) not in values:
                return
        given = [k for k in rule.keys if k in doc]
        words = " or ".join(rule.keys)
        cond = "" if rule.when is None else f" for {_cond(rule.when)}"
        if not given:
            self.missing(_join(dpath, rule.keys[0]), f"exactly one of {words}{cond}")
        elif len(given) > 1:
            p = _join(dpath, given[1])
            self.invalid(p, doc[given[1]], f"exactly one of {words}{cond}, not both")


def _deciders(rows: Sequence[Field]) -> set[str]:
    out = {r.when[0] for r in rows if r.when}
    out |= {r.required_when[0] for r in rows if r.required_when}
    return out


def _fields_by_path() -> dict[str, tuple[Field, ...]]:
    out: dict[str, list[Field]] = {}
    for f in SCHEMA:
        out.setdefault(f.path, []).append(f)
    return {k: tuple(v) for k, v in out.items()}


_FIELDS_BY_PATH = _fields_by_path()

_CAUGHT = (ModelError, TypeError, ValueError, ArithmeticError)


# --------------------------------------------------------------------------------------------
# Building the model from checked values
# --------------------------------------------------------------------------------------------


def _build_structure(ck: _Checker, s: Mapping[str, Any]) -> Structure | None:
    if not ck.ok("structure"):
        return None
    if s["kind"] == "beam":
        from vibroimpact.fe.beam import beam_from_table

        try:
            beam = beam_from_table(s)
            structure = beam.structure
        except _CAUGHT as e:
            ck.add("structure", _reprefix(e, {}, "structure"))
            return None
        ck.context["beam"] = beam
        return structure
    try:
        if s["kind"] == "sdof":
            return Structure.sdof(
                mass=s["mass"], stiffness=s.get("stiffness", 0.0), damping=s.get("damping", 0.0)
            )
        if s["kind"] == "jeffcott":
            pair = {k: list(v) if isinstance(v := s[k], tuple) and len(v) > 1 else
                    v[0] if isinstance(v, tuple) else v for k in ("stiffness", "damping")}
            return Structure.jeffcott(mass=s["mass"], **pair, spin_speed=s["spin_speed"])
    except _CAUGHT as e:
        ck.add("structure", _reprefix(e, {}, "structure"))
        return None
    return _build_matrices(ck, s)


def _build_matrices(ck: _Checker, s: Mapping[str, Any]) -> Structure | None:
    """``kind = "matrices"``: read the matrices (inline or files, :func:`vibroimpact.fe.
    matrices.read_matrix_files`), condense a singular mass statically (massless DOFs, or its
    whole null space: :mod:`vibroimpact.fe.condensation`), then build ``[structure.damping]``
    on the model that runs. Keeps the full :class:`~vibroimpact.fe.FEStructure` in
    ``ck.context["fe"]`` (DOF map, massless DOFs) and the condensation, if any."""
    keys = [k for k in ("mass", "stiffness", "damping", "gyroscopic")
            if k in s and isinstance(s[k], _Matrix)]
    got = read_matrix_files(
        {k: s[k].source for k in keys},
        format=s["format"],
        dof_map=s.get("dof_map"),
        shown={k: s[k].shown for k in keys},
    )
    for key, line in got.errors.items():
        ck.add(f"structure.{key}", f"structure.{key}: {line}")
    if not ck.ok("structure"):
        return None
    m = got.matrices
    try:
        fe = FEStructure(m["mass"], m.get("stiffness", 0 * m["mass"]), m.get("damping"),
                         got.dof_map, s.get("dof_units"), gyroscopic=m.get("gyroscopic"),
                         spin_speed=s["spin_speed"])
    except _CAUGHT as e:
        ck.add("structure", _reprefix(e, {}, "structure"))
        return None
    ck.context["fe"] = fe
    try:
        run: FEStructure = fe
        if fe.singular_mass:
            cond = fe.condense_massless()
            ck.context["condensation"] = cond
            run = cond.structure
        rule = s.get("damping")
        if isinstance(rule, dict):
            run = run.with_damping(damping_from_table(rule))
        return run.to_structure()
    except _CAUGHT as e:
        ck.add("structure", _reprefix(e, {}, "structure"))
        return None


def _n_dof(structure: Mapping[str, Any]) -> int | None:
    """The number of DOFs, if the structure tells it despite its mistakes."""
    if structure.get("kind") == "sdof":
        return 1
    if structure.get("kind") == "jeffcott":
        return 2
    mass = structure.get("mass")
    if isinstance(mass, _Matrix) and not isinstance(mass.source, Path):
        return int(mass.source.shape[0])
    return None


def _check_dofs(ck: _Checker, p: str, dofs: Sequence[int], n: int | None) -> None:
    if n is None:
        return
    bad = [d for d in dofs if d >= n]
    if bad:
        ck.invalid(p, bad[0], f"0 <= dof < {n} (the structure has {n} DOF{'s' * (n != 1)})")


_KIND_WORDS = {"beam": "a beam", "matrices": "matrices"}


def _node_dofs(
    ck: _Checker, p: str, t: Mapping[str, Any], *, many: bool
) -> tuple[int, ...] | None:
    """The DOF(s) of a gap (``dof``, or ``node`` (beam: or ``at``) and ``direction``) or a load
    (``dof``, or ``nodes`` and ``direction``) on a beam or on matrices with a DOF map; None
    after recording a mistake (or when the structure has mistakes of its own)."""
    kind = ck.context.get("structure.kind")
    keys = ("dof", "nodes") if many else ("dof", "node", "at")[: 3 if kind == "beam" else 2]
    given = [k for k in keys if k in t]
    words = " or ".join(keys)
    if not given:
        ck.missing(f"{p}.{keys[0]}", f"exactly one of {words} for {_KIND_WORDS[kind]}")
        return None
    if len(given) > 1:
        q = f"{p}.{given[1]}"
        ck.invalid(q, ck.raw.get(q), f"exactly one of {words}, not both")
        return None
    if given[0] == "dof":
        return tuple(t["dof"])
    q = f"{p}.{given[0]}"
    owner = ck.context.get("beam") if kind == "beam" else ck.context.get("fe")
    if owner is None:
        return None
    if kind == "matrices" and owner.dof_map is None:
        ck.invalid(
            q, ck.raw.get(q), "dof, or a DOF map to address DOFs by node: structure.dof_map, "
            "or CalculiX/ABAQUS/.npz matrix files that carry one",
        )
        return None
    try:
        if many:
            nodes = t["nodes"] if t["nodes"] == "all" else list(t["nodes"])
            return tuple(owner.dofs(nodes, t["direction"]))
        if kind == "beam":
            return (owner.dof(t.get("node"), at=t.get("at"), direction=t["direction"]),)
        return (owner.dof(t["node"], t["direction"]),)
    except _CAUGHT as e:
        where = {k: q for k in ("node", "at", "nodes")}
        line = _reprefix(e, {**where, "direction": f"{p}.direction"}, p)
        ck.add(line.split(":", 1)[0], line)
        return None


def _shell_node(ck: _Checker, g: Mapping[str, Any]) -> tuple[list[int], list[float]] | None:
    """The layers and weights of the gap's ``node``/``direction`` if CalculiX expanded it
    (:meth:`~vibroimpact.fe.dofs.DofMap.shell_weights`), else None."""
    dm = getattr(ck.context.get("fe"), "dof_map", None)
    if dm is None or "node" not in g or "direction" not in g:
        return None
    try:
        if not dm.layer_dofs(g["node"], g["direction"]):
            return None
        return dm.shell_weights(g["node"], g["direction"])
    except _CAUGHT:
        return None  # _node_dofs names the mistake


def _shell_load(ck: _Checker, ld: Mapping[str, Any], n: int | None
                ) -> NDArray[np.float64] | None:
    """The weights per DOF of a load by ``nodes``/``direction`` with a node that CalculiX
    expanded into layers (:meth:`~vibroimpact.fe.dofs.DofMap.shell_load_weights`: how ccx
    spreads a ``*CLOAD`` on it), else None."""
    dm = getattr(ck.context.get("fe"), "dof_map", None)
    nodes, direction = ld.get("nodes"), ld.get("direction")
    if dm is None or direction is None or isinstance(nodes, str) or nodes is None or "dof" in ld:
        return None  # _node_dofs checks what is given
    try:
        if not any(dm.layer_dofs(node, direction) for node in nodes):
            return None
        w = np.zeros(len(dm.nodes))
        for node in nodes:
            dofs, weights = dm.shell_load_weights(node, direction)
            w[dofs] += weights
        return w
    except _CAUGHT:
        return None  # _node_dofs names the mistake


def _dof_label(ck: _Checker, dof: int) -> str:
    dm = ck.context["fe"].dof_map
    layer = "" if dm is None or not dm.layers[dof] else f" layer {dm.layers[dof]}"
    at = "" if dm is None else f" (node {dm.nodes[dof]} direction {dm.directions[dof]!r}{layer})"
    return f"DOF {dof}{at}"


def _build_radial_gap(ck: _Checker, gp: str, g: Mapping[str, Any],
                      n: int | None) -> RadialGap | None:
    """A radial gap: on ``dof = [ix, iy]``, or on ``directions`` (default x, y) at ``node``."""
    by_node = ck.context.get("structure.kind") in _WITH_NODES[1]
    directions = g.get("directions")
    if directions is not None and (not by_node or len(directions) != 2):
        ck.invalid(f"{gp}.directions", ck.raw.get(f"{gp}.directions"),
                   "two directions [x, y] with node, on a beam or matrices" if by_node else
                   "no directions without nodes (give dof = [ix, iy])")
        return None
    if by_node and "dof" not in g:
        dofs: tuple[int, ...] = ()
        for d in directions or ("x", "y"):
            got = _node_dofs(ck, gp, {**g, "direction": d}, many=False)
            if not got:
                return None
            dofs += got
    else:
        dofs = tuple(g.get("dof") or ())
    _check_dofs(ck, f"{gp}.dof", dofs, n)
    if "condensation" in ck.context:
        ck.invalid(f"{gp}.kind", "radial", "a structure without massless DOFs (a radial gap is "
                   "not condensed)")
    law = _build_law(ck, f"{gp}.law", g["law"])
    if law is None or not ck.ok(gp):
        return None
    try:
        return RadialGap(dof=list(dofs), law=law, clearance=g["clearance"], center=g["center"],
                         friction=g["friction"], radius=g.get("radius"),
                         friction_law=g["friction_law"],
                         regularisation_speed=g.get("regularisation_speed"), name=g.get("name"))
    except _CAUGHT as e:
        ck.add(gp, _reprefix(e, {"gap": gp, "law": f"{gp}.law"}, gp))
        return None


def _build_gap(ck: _Checker, i: int, g: Mapping[str, Any], n: int | None) -> Gap | None:
    gp = f"gaps[{i}]"
    if not ck.ok(gp):
        return None
    if g["kind"] == "radial":
        return _build_radial_gap(ck, gp, g, n)
    by_node = ck.context.get("structure.kind") in _WITH_NODES[1]
    coefficients = g.get("coefficients")
    shell = _shell_node(ck, g) if by_node and coefficients is None else None
    if shell is not None:  # a CalculiX shell node: the mean of its layers
        dofs, coefficients = tuple(shell[0]), shell[1]
    else:
        dofs = (_node_dofs(ck, gp, g, many=False) if by_node else g.get("dof")) or ()
    _check_dofs(ck, f"{gp}.dof", dofs, n)
    if coefficients is not None:
        if len(coefficients) != len(dofs):
            ck.invalid(
                f"{gp}.coefficients",
                ck.raw.get(f"{gp}.coefficients"),
                f"{len(dofs)} number{'s' * (len(dofs) != 1)} (one per dof)",
            )
        elif not any(c != 0 for c in coefficients):
            ck.invalid(
                f"{gp}.coefficients", ck.raw.get(f"{gp}.coefficients"), "numbers not all zero"
            )
    law = _build_law(ck, f"{gp}.law", g["law"])
    if law is None or not ck.ok(gp) or not dofs:
        return None
    try:
        gap = Gap(
            dof=dofs if len(dofs) > 1 else dofs[0],
            law=law,
            clearance=g["clearance"],
            side=g["side"],
            coefficients=coefficients,
            name=g.get("name"),
        )
        cond = ck.context.get("condensation")
        if cond is None:
            return gap
        ck.context.setdefault("file_gaps", []).append(gap)
        return cond.reduce_gap(gap)
    except _CAUGHT as e:
        ck.add(gp, _reprefix(e, {"gap": gp, "law": f"{gp}.law"}, gp))
        return None


def _build_law(ck: _Checker, lp: str, law: Mapping[str, Any]) -> contact.ContactLaw | None:
    kind = law["kind"]
    params = {k: v for k, v in law.items() if k not in ("kind", "geometry")}
    if "geometry" in law:
        geo = law["geometry"]
        gp = f"{lp}.geometry"
        try:
            geometry = contact.Geometry(**geo)
            k = geometry.stiffness()
        except _CAUGHT as e:
            ck.add(gp, _reprefix(e, {"geometry": gp}, gp))
            return None
        if not (math.isfinite(k) and k > 0):
            ck.invalid(gp, geo, f"radii and materials giving a finite stiffness > 0 (got {k!r})")
            return None
        params["stiffness"] = geometry
    try:
        return contact.LAWS[kind](**params)
    except _CAUGHT as e:
        ck.add(lp, _reprefix(e, {"law": lp, "geometry": f"{lp}.geometry"}, lp))
        return None


def _build_load(
    ck: _Checker, i: int, ld: Mapping[str, Any], n: int | None
) -> list[Load | UnbalanceLoad] | None:
    """The load ``loads[i]`` (several on a condensed model: one per generalized weight)."""
    lp = f"loads[{i}]"
    if not ck.ok(lp):
        return None
    if ld["kind"] == "unbalance":
        return _build_unbalance(ck, lp, ld, n)
    by_node = ck.context.get("structure.kind") in _WITH_NODES[1]
    shell = _shell_load(ck, ld, n) if by_node else None
    dofs: tuple[int, ...]
    if shell is not None:
        dofs = tuple(int(j) for j in np.flatnonzero(shell))
    else:
        dofs = (_node_dofs(ck, lp, ld, many=True) if by_node else ld.get("dof")) or ()
    _check_dofs(ck, f"{lp}.dof", dofs, n)
    if not ck.ok(lp) or not dofs:
        return None
    dof = dofs if len(dofs) > 1 else dofs[0]
    try:
        load: Load
        if ld["kind"] == "constant":
            load = ConstantLoad(dof=dof, amplitude=ld["amplitude"])
        elif ld["kind"] == "harmonic":
            load = HarmonicLoad(
                dof=dof, amplitude=ld["amplitude"], frequency=ld["frequency"], phase=ld["phase"]
            )
        else:
            table: _Table = ld["file"]
            load = TableLoad(dof=dof, time=table.time, force=table.force, scale=ld["scale"])
        loads = [load] if shell is None else weighted_loads(load, shell)
        cond = ck.context.get("condensation")
        if cond is None:
            return list(loads)
        ck.context.setdefault("file_loads", []).extend(loads)
        return [r for one in loads for r in cond.reduce_load(one)]
    except _CAUGHT as e:
        ck.add(lp, _reprefix(e, {"load.table": f"{lp}.file", "load": lp}, lp))
        return None


def _build_unbalance(
    ck: _Checker, lp: str, ld: Mapping[str, Any], n: int | None
) -> list[Load | UnbalanceLoad] | None:
    """An unbalance load: on ``dof = [ix, iy]``, or on the x and y of ``node`` (beam,
    matrices with a DOF map)."""
    given = [k for k in ("dof", "node") if k in ld]
    if len(given) != 1:
        ck.invalid(f"{lp}.node" if given else f"{lp}.dof", ck.raw.get(f"{lp}.node"),
                   "exactly one of dof = [ix, iy] or node")
        return None
    if "dof" in ld:
        dofs = tuple(ld["dof"])
    else:
        kind = ck.context.get("structure.kind")
        owner = ck.context.get("beam") if kind == "beam" else ck.context.get("fe")
        if kind not in _WITH_NODES[1] or getattr(owner, "dof_map", None) is None:
            ck.invalid(f"{lp}.node", ck.raw.get(f"{lp}.node"), "dof = [ix, iy], or a beam or "
                       "matrices with a DOF map to address a node")
            return None
        try:
            node = ld["node"]
            dofs = tuple(owner.dof(node, direction=d) if kind == "beam" else owner.dof(node, d)
                         for d in ("x", "y"))
        except _CAUGHT as e:
            ck.add(f"{lp}.node", _reprefix(e, {"node": f"{lp}.node", "direction":
                                               f"{lp}.node"}, lp))
            return None
    _check_dofs(ck, f"{lp}.dof", dofs, n)
    if "condensation" in ck.context:
        ck.invalid(f"{lp}.kind", "unbalance", "a structure without massless DOFs (an unbalance "
                   "load is not condensed)")
    if not ck.ok(lp):
        return None
    try:
        return [UnbalanceLoad(dof=dofs, magnitude=ld["magnitude"], phase=ld["phase"])]
    except _CAUGHT as e:
        ck.add(lp, _reprefix(e, {"load": lp}, lp))
        return None


def _output_dofs(ck: _Checker, output: Mapping[str, Any], n: int | None) -> list[int] | None:
    """The file's DOFs that ``[output]`` keeps: ``dofs``, or every DOF of ``directions`` (all
    of each node's) at ``nodes``; None for all."""
    if "nodes" not in output:
        if "directions" in output:
            ck.invalid("output.directions", ck.raw.get("output.directions"),
                       "directions with output.nodes")
        dofs = output.get("dofs")
        if dofs is not None:
            _check_dofs(ck, "output.dofs", dofs, n)
        return None if dofs is None else list(dofs)
    if "dofs" in output:
        ck.invalid("output.nodes", ck.raw.get("output.nodes"), "exactly one of dofs or nodes")
        return None
    kind = ck.context.get("structure.kind")
    beam = ck.context.get("beam")
    dof_map = beam.dof_map if beam is not None else getattr(ck.context.get("fe"), "dof_map", None)
    if dof_map is None:
        if kind == "matrices" and "fe" in ck.context:
            ck.invalid("output.nodes", ck.raw.get("output.nodes"), "output.dofs, or a DOF map "
                       "to address DOFs by node: structure.dof_map, or CalculiX/ABAQUS/.npz "
                       "matrix files that carry one")
        return None
    try:
        nodes = output["nodes"]
        if nodes == "all":
            nodes = dof_map.node_labels
        if beam is not None:
            nodes = [beam.node_index(x, field_name="output.nodes") for x in nodes]
        out: list[int] = []
        for node in nodes:
            at_node = [d for nn, d in zip(dof_map.nodes, dof_map.directions, strict=True)
                       if nn == node]
            directions = output.get("directions") or list(dict.fromkeys(at_node))
            out += dof_map.all_dofs([node], directions)
    except _CAUGHT as e:
        where = {"node": "output.nodes", "nodes": "output.nodes", "direction": "output.directions"}
        line = _reprefix(e, where, "output")
        ck.add(line.split(":", 1)[0], line)
        return None
    return list(dict.fromkeys(out))


def _build_initial(
    ck: _Checker, initial: Mapping[str, Any], n: int | None
) -> dict[str, NDArray[np.float64] | None]:
    out: dict[str, NDArray[np.float64] | None] = {}
    for key, unit in (("displacement", "m"), ("velocity", "m/s")):
        p = f"initial.{key}"
        values = initial.get(key)
        if values is None or not ck.ok(p):
            out[key] = None
            continue
        if n is not None and len(values) != n:
            what = "a number" if n == 1 else f"a list of {n} numbers (one per DOF)"
            ck.invalid(p, ck.raw.get(p), f"{what} in {unit}")
            out[key] = None
            continue
        x = np.asarray(values, dtype=float)
        cond = ck.context.get("condensation")
        problem = None if cond is None else cond.state_problem(x)
        if problem is not None:
            moved = [int(d) for d in cond.condensed if x[d] != 0]
            if moved:  # a massless DOF's value follows from the others: give 0
                problem = (f"0 on the massless {_dof_label(ck, moved[0])} (it is condensed out "
                           "statically, its value follows from the others), or there the "
                           f"static value of the others, not {float(x[moved[0]])!r}")
            ck.invalid(p, ck.raw.get(p), problem)
            out[key] = None
            continue
        if cond is not None:
            x = cond.reduce_state(x)
        out[key] = x
    return out


def _option_types(method: str) -> dict[str, str]:
    """The ``[solver]`` options of ``method`` and their type names (for "did you mean" and
    type checks; empty if the method is unknown)."""
    if method not in integrators.METHODS:
        return {}
    return {k: t for k, (t, _) in integrators.method_options(method).items()}


_ANNOTATION_CHECKS: dict[str, tuple[str, Callable[[Any], bool]]] = {
    "float": ("a number", lambda v: isinstance(v, (int, float)) and not isinstance(v, bool)),
    "int": ("an integer", _is_int),
    "bool": ("true or false", lambda v: isinstance(v, bool)),
    "str": ("a string", lambda v: isinstance(v, str)),
}


def _build_method(ck: _Checker, solver: Mapping[str, Any]) -> Integrator | None:
    name = solver.get("method")
    if name is None or not ck.ok("solver.method"):
        return None
    options: dict[str, Any] = dict(solver.get(_EXTRA, {}))
    try:
        method_from_options(name, {})
    except _CAUGHT as e:
        ck.add("solver.method", _reprefix(e, {}, "solver.method"))
        return None
    known = _option_types(name)
    before = len(ck.errors)
    unknown: dict[str, list[str]] = {}
    for key, value in options.items():
        p = _join("solver", key)
        check = _ANNOTATION_CHECKS.get(known.get(key, ""))
        if check is not None and not check[1](value):
            ck.invalid(p, value, f"{check[0]} (option {key} of method {name!r})")
            continue
        # an adaptive tolerance is checked on its own, as if adaptive stepping were on
        context = {"adaptive": True} if key in integrators.ADAPTIVE_KEYS else {}
        try:
            method_from_options(name, {**context, key: value})
        except _CAUGHT as e:
            if known and key not in known:
                unknown[key] = ["method", "dt", "t_end", *known]
            elif isinstance(e, ModelError):
                ck.add(p, _reprefix(e, {}, p))
            else:
                ck.invalid(p, value, f"a valid {key} for method {name!r} ({_one_line(e)})")
    ck.unknown_keys("solver", "solver", unknown, solver)
    if len(ck.errors) > before:
        return None
    try:
        return method_from_options(name, options)
    except _CAUGHT as e:
        ck.add("solver", _reprefix(e, {}, "solver"))
        return None


def _check_document(doc: Mapping[str, Any], path: Path) -> ModelFile:
    ck = _Checker(path.parent)
    kind = doc.get("structure", {}).get("kind") if isinstance(doc.get("structure"), dict) else None
    if kind in ("sdof", "matrices", "beam", "jeffcott"):
        ck.context["structure.kind"] = kind
    top = ck.table("", "", doc)
    structure = _build_structure(ck, top["structure"]) if "structure" in top else None
    if structure is not None and top["structure"].get("spin_profile") == "linear":
        try:
            structure = structure.run_up(top["structure"]["spin_speed_end"],
                                         top["structure"]["run_up_time"])
        except _CAUGHT as e:
            ck.add("structure", _reprefix(e, {}, "structure"))
            structure = None
    if "fe" in ck.context:  # matrices: DOF indices in the file count the file's DOFs
        n: int | None = ck.context["fe"].n_dof
    else:
        n = structure.n_dof if structure is not None else _n_dof(top.get("structure", {}))
    gaps = [_build_gap(ck, i, g, n) for i, g in enumerate(top.get("gaps", []))]
    if "condensation" in ck.context and ck.ok("gaps"):
        try:
            ck.context["condensation"].check_gaps(ck.context.get("file_gaps", []))
        except _CAUGHT as e:
            ck.add(str(e).split(":", 1)[0], str(e))
    loads = [_build_load(ck, i, ld, n) for i, ld in enumerate(top.get("loads", []))]
    if "condensation" in ck.context and ck.ok("gaps") and ck.ok("loads"):
        try:  # a load coupled to a gap through the massless modes
            ck.context["condensation"].output([], ck.context.get("file_gaps", []),
                                              ck.context.get("file_loads", []))
        except _CAUGHT as e:
            ck.add(str(e).split(":", 1)[0], str(e))
    dofs = _output_dofs(ck, top.get("output", {}), n)
    initial = _build_initial(ck, top.get("initial", {}), n)
    solver = top.get("solver", {})
    dt, t_end = solver.get("dt"), solver.get("t_end")
    if dt is not None and t_end is not None and dt > t_end:
        ck.invalid(
            "solver.dt", ck.raw.get("solver.dt"), f"dt <= t_end = {ck.raw['solver.t_end']!r}"
        )
    method = _build_method(ck, solver) if "solver" in top else None
    output = top.get("output", {})
    if ck.errors:
        raise ModelFileError(ck.lines())
    assert structure is not None and method is not None and dt is not None and t_end is not None
    try:
        model = Model(
            structure,
            gaps=[g for g in gaps if g is not None],
            loads=[x for ld in loads if ld is not None for x in ld],
            initial_displacement=initial["displacement"],
            initial_velocity=initial["velocity"],
        )
        # energies, forces and time scales that are not finite doubles (docs/model-file.md)
        check_run(model, t_end, dt, method)
        contact_periods(model)
    except _CAUGHT as e:  # their messages start with the TOML path of the field
        raise ModelFileError([_one_line(e)]) from None
    return ModelFile(
        model=model,
        t_end=t_end,
        dt=dt,
        method=method,
        every=output.get("every", 1),
        dofs=dofs,
        path=path,
        beam=ck.context.get("beam"),
        condensation=ck.context.get("condensation"),
        file_gaps=tuple(ck.context.get("file_gaps", ())),
        file_loads=tuple(ck.context.get("file_loads", ())),
        dof_map=_file_dof_map(ck, top.get("structure", {}).get("kind")),
    )


def _file_dof_map(ck: _Checker, kind: str | None) -> DofMap | None:
    """The DOF map of a checked file's structure (:attr:`ModelFile.dof_map`)."""
    if kind == "jeffcott":
        return Structure.jeffcott(mass=1.0, stiffness=0.0).dof_map
    owner = ck.context.get("beam") or ck.context.get("fe")
    return getattr(owner, "dof_map", None)


# --------------------------------------------------------------------------------------------
# The public API
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelFile:
    """A checked model file: the :class:`~vibroimpact.Model` and how to run it
    (``t_end`` and ``dt`` in s, the integrator, output decimation ``every`` and the recorded
    ``dofs`` of the file, ``output.dofs``, None for all). ``path`` is the file it was read
    from. Run it with :meth:`simulate`, or pass :attr:`run_dofs` to
    :func:`vibroimpact.simulate` and its result through :meth:`relabel`."""

    model: Model
    t_end: float
    dt: float
    method: Integrator
    every: int
    dofs: list[int] | None
    path: Path
    #: The :class:`vibroimpact.fe.Beam` of a ``structure.kind = "beam"`` file (its DOF map and
    #: node positions), else None.
    beam: Any = None
    #: The :class:`vibroimpact.fe.StaticCondensation` of a ``kind = "matrices"`` file with
    #: massless DOFs, else None. The model then has the DOFs with mass only: its DOF ``k`` is
    #: the file's DOF ``condensation.retained[k]`` (gaps, loads, ``[initial]`` and
    #: ``output.dofs`` in the file count the file's DOFs); :meth:`simulate` reports the
    #: file's DOFs, the condensed ones recovered (:class:`vibroimpact.fe.condensation.DofRecovery`).
    condensation: Any = None
    #: The gaps on the file's DOFs (of a condensed model: :attr:`model` has them reduced),
    #: which :meth:`recovery` needs for the contact's part in the massless modes.
    file_gaps: tuple[Gap, ...] = ()
    #: The loads on the file's DOFs, whose part in the massless modes :meth:`recovery` adds.
    file_loads: tuple[Load, ...] = ()
    #: The node and direction of each of the file's DOFs (a beam's, a matrices file's DOF
    #: map, a Jeffcott rotor's node 0 x and y), which :meth:`simulate` gives its result; None
    #: for other structures.
    dof_map: DofMap | None = None

    @property
    def run_dofs(self) -> list[int] | None:
        """The DOFs of :attr:`model` to record (``dofs`` of :func:`vibroimpact.simulate`;
        None for all) so that :meth:`recovery` can report :attr:`dofs`."""
        if self.condensation is None or self.dofs is None:
            return self.dofs
        return self.condensation.output(self.dofs, self.file_gaps, self.file_loads).record.tolist()

    def recovery(self) -> DofRecovery | None:
        """A fresh :class:`~vibroimpact.fe.condensation.DofRecovery` that turns a run of
        :attr:`model` (recording :attr:`run_dofs`) into the file's DOFs; None if the model is
        the file's (no condensation)."""
        if self.condensation is None:
            return None
        return self.condensation.output(self.dofs, self.file_gaps, self.file_loads)

    def simulate(self, *, throw: bool = True, progress: bool = False) -> Result:
        """Run the model with the file's solver and output settings
        (:func:`vibroimpact.simulate`, ``throw`` and ``progress`` as there); the result's DOFs
        are the file's (``output.dofs``, massless ones recovered), also in a
        :class:`~vibroimpact.SolverError`'s ``partial``."""
        from vibroimpact.simulate import simulate

        recovery = self.recovery()

        def for_file(result: Result) -> Result:
            result = result if recovery is None else recovery.result(result)
            return dataclasses.replace(result, dof_map=self.dof_map)

        try:
            result = simulate(self.model, t_end=self.t_end, dt=self.dt, method=self.method,
                              every=self.every, dofs=self.run_dofs, throw=throw,
                              progress=progress)
        except SolverError as e:
            if e.partial is not None:
                e.partial = for_file(e.partial)
            raise
        return for_file(result)


_TOML_POSITION = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


def _parse(text: str, name: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = _one_line(e)
        m = _TOML_POSITION.search(msg)
        if m:
            where = f"{name}:{m.group(1)}:{m.group(2)}"
            msg = msg[: m.start()]
        else:
            msg = re.sub(r"\s*\(at end of document\)\s*$", "", msg)
            where = f"{name}:{max(1, len(text.splitlines()))}"
        raise ModelFileError(
            [f"{where}: invalid TOML syntax ({msg}); expected a TOML document (toml.io)"]
        ) from None


def load_model(path: str | os.PathLike[str]) -> ModelFile:
    """Read and check a model file (see ``docs/model-file.md``).

    Every mistake is found before anything runs; all of them are raised together as a
    :class:`ModelFileError` whose ``errors`` hold one line each, naming the key's TOML path
    (``gaps[1].law.restitution``), the value and what was expected. Relative file paths in the
    model (matrices, load tables) are relative to the model file's folder.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as e:
        raise ModelFileError(
            [
                f"{p}: cannot read the model file ({e.strerror or type(e).__name__}); "
                "expected an existing, readable TOML file"
            ]
        ) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        raise ModelFileError(
            [
                f"{p.name}:{line}: invalid TOML (byte {data[e.start]:#04x} is not UTF-8); "
                "expected a UTF-8 text file"
            ]
        ) from None
    doc = _parse(text, p.name)
    return _check_document(doc, p)


# --------------------------------------------------------------------------------------------
# The reference
# --------------------------------------------------------------------------------------------

#: The example shown at the top of the reference (the paper's SDOF case, docs/paper-cases.md).
EXAMPLE = """\
schema_version = 1

[structure]            # a 100 kg block, no spring
kind = "sdof"
mass = 100.0           # kg

[[gaps]]               # walls 5 mm away on both sides
dof = 0
clearance = 0.005      # m
side = "both"

[gaps.law]
kind = "lankarani-nikravesh"
exponent = 1.5
restitution = 0.9

[gaps.law.geometry]    # K = (4/3) E* sqrt(R*) (paper eq. 4)
kind = "ball-in-socket"
radius1 = 0.010        # m
radius2 = 0.0099       # m
youngs_modulus = 207e9 # Pa
poisson = 0.3

[initial]
velocity = 8.0         # m/s

[solver]
method = "newmark"
dt = 1e-6              # s
t_end = 0.02           # s
"""


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _default_cell(f: Field) -> str:
    if f.default is REQUIRED:
        return "**required**"
    if f.required_when is not None and f.required_when[1]:
        return f"required for {_cond(f.required_when)}"
    if f.default_text:
        return f.default_text
    if f.default is None:
        return "—"
    return f"`{_toml(f.default)}`"


def _allowed_cell(f: Field) -> str:
    parts = []
    if f.choices:
        parts.append(", ".join(f"`{_toml(c)}`" for c in f.choices))
    rng = f.range_text()
    if rng:
        parts.append(rng.removeprefix("with "))
    if f.rule:
        parts.append(f.rule)
    return "; ".join(parts) or "—"


def _methods_section() -> list[str]:
    lines = ["## Solver methods", ""]
    lines.append(
        "`[solver] method` names an integrator of `vibroimpact.integrators`; the other keys "
        "of `[solver]` (besides `dt` and `t_end`) are its options."
    )
    lines.append("")
    lines += ["| method | options (default) |", "|---|---|"]
    for name in integrators.METHODS:
        opts = [f"`{k}` ({_toml(d)})" for k, (_, d) in integrators.method_options(name).items()]
        lines.append(f"| `{name}` | {', '.join(opts)} |")
    lines += [
        "",
        "`newton_rtol`, `newton_atol` (m), `max_iterations` and `max_step_cuts` control Newton "
        "(paper eq. 27); `adaptive = true` switches on adaptive stepping with the local-error "
        "tolerances `rtol`, `atol` (m) and the step limits `dt_min`, `dt_max` (s).",
    ]
    return [*lines, ""]


_SECTION_TITLES = {
    "": "Top level",
    "structure": "`[structure]`",
    "structure.section": "`[structure.section]` (beam)",
    "structure.material": "`[structure.material]` (beam)",
    "structure.supports[]": "`[[structure.supports]]` (beam, any number)",
    "structure.springs[]": "`[[structure.springs]]` (beam, any number)",
    "structure.masses[]": "`[[structure.masses]]` (beam, any number)",
    "structure.discs[]": "`[[structure.discs]]` (beam rotor, any number)",
    "structure.bearings[]": "`[[structure.bearings]]` (beam rotor, any number)",
    "structure.damping": "`[structure.damping]` (beam, matrices)",
    "gaps[]": "`[[gaps]]` (any number)",
    "gaps[].law": "`[gaps.law]`",
    "gaps[].law.geometry": "`[gaps.law.geometry]`",
    "initial": "`[initial]`",
    "loads[]": "`[[loads]]` (any number)",
    "solver": "`[solver]`",
    "output": "`[output]`",
}


def render_reference() -> str:
    """The model-file reference (markdown) rendered from :data:`SCHEMA` and :data:`RULES`;
    committed as ``docs/model-file.md``."""
    out = [
        "# Model file reference",
        "",
        "<!-- Generated from vibroimpact.io.model_file (SCHEMA, RULES); do not edit by hand.",
        "     Regenerate it with `python -m vibroimpact.docs`. -->",
        "",
        "A model file is [TOML](https://toml.io) describing a linear structure with clearances,",
        "its loads, its initial state and how to integrate it. Units are SI throughout.",
        "Run one with `vibroimpact run MODEL.toml` or read it with",
        "`vibroimpact.io.load_model(path)`. File paths inside a model file are relative to the",
        "folder of the model file.",
        "",
        "## Example: the paper's SDOF case",
        "",
        "```toml",
        EXAMPLE.rstrip("\n"),
        "```",
        "",
    ]
    for section, title in _SECTION_TITLES.items():
        rows = _CHILDREN.get(section, ())
        if not rows:
            continue
        out += [f"## {title}", ""]
        out += [
            "| key | type | unit | default | allowed | applies when | description |",
            "|---|---|---|---|---|---|---|",
        ]
        for f in rows:
            when = _cond(f.when) if f.when is not None else "always"
            if f.when is not None and len(f.when[1]) == len(_LAW_KINDS) and "law" in f.parent:
                when = "always"
            kind = TYPES[f.type].name
            cells = [
                f"`{f.key}`",
                kind,
                f.unit or "—",
                _default_cell(f),
                _allowed_cell(f),
                when,
                f.description,
            ]
            out.append("| " + " | ".join(_cell(c) for c in cells) + " |")
        if section == "solver":
            out.append("| *other keys* | | | | | always | options of the method, see below |")
        out.append("")
    out += ["## Rules between keys", ""]
    out += [f"* {rule.text()}" for rule in RULES]
    out += [
        "* Every DOF index (`gaps.dof`, `loads.dof`, `output.dofs`) is below the number of DOFs.",
        "* `[[gaps]] coefficients` has one number per `dof`, not all zero.",
        "* On a beam (`structure.kind = \"beam\"`) each `[[gaps]]` gives exactly one of `dof`,",
        "  `node`, `at` and each `[[loads]]` one of `dof`, `nodes`; nodes are indices from 0",
        "  (`\"start\"`) to `elements` (`\"end\"`); `at` must fall on a node.",
        "* On matrices (`structure.kind = \"matrices\"`) each `[[gaps]]` gives exactly one of",
        "  `dof`, `node` and each `[[loads]]` one of `dof`, `nodes`; a node is a node label of the",
        "  DOF map, which `structure.dof_map` gives or the matrix files carry (CalculiX `job.dof`,",
        "  ABAQUS node/DOF entries, `.npz` `dof_nodes`/`dof_directions`); `.mtx` (Matrix Market)",
        "  and `.npy` files carry none.",
        "* `[initial]` has one value per DOF; `solver.dt <= solver.t_end`.",
        "* `structure.stiffness` and `structure.damping` have the shape of `structure.mass`",
        "  (with a DOF map: one row per DOF of it; CalculiX and ABAQUS files may omit trailing",
        "  zero rows); all three are symmetric and `structure.mass` is positive semi-definite",
        "  (its null space is condensed out, see Massless DOFs).",
        "* `[output]` gives at most one of `dofs`, `nodes` (beam, matrices); `directions` only",
        "  with `nodes`. On matrices a node with layers (CalculiX's expanded shell nodes) gives",
        "  every layer's DOF.",
        "* `[structure.damping]` on matrices is built on the model that runs (massless DOFs and",
        "  modes condensed): Rayleigh `αM + βK` or modal, as for beams; `structure.damping` is",
        "  either that table or a damping matrix.",
        "",
        "## Numbers whose energy, force or time scale is not a double",
        "",
        "Every number must be finite, and so must what follows from them before the run, each",
        "refused on one line naming the field responsible (`vibroimpact.simulate` and building a",
        "`vibroimpact.Model` refuse the same with a `ModelError`):",
        "",
        "* `[initial]`: the kinetic energy `1/2 vᵀMv` (`initial.velocity`), the strain energy",
        "  `1/2 xᵀKx` (`initial.displacement`) and, for each gap that the initial state already",
        "  closes, the law's contact force at that penetration and speed.",
        "* `[structure]`: on every DOF `K_ii / M_ii` (a squared natural frequency) and",
        "  `C_ii / M_ii` (a decay rate).",
        "* `[[loads]]`: the largest force (`scale` times the table's largest `|F|`) and the",
        "  energy `1/2 (F t_end)² Σ 1/M_dd` that its impulse over the run would give the masses",
        "  of its DOFs `d` if nothing held them (`amplitude`, or `scale` of a table).",
        "* `[[gaps]]`: the estimated contact period `2π √(m_eff / k)` (effective mass, the",
        "  law's secant stiffness at the penetration that stores the energy the run can bring,",
        "  `vibroimpact.simulate.contact_periods`) is a finite number > 0.",
        "* Time scale: `solver.dt` and `solver.t_end` are finite and > 0, `dt <= t_end`, and",
        "  with fixed steps `t_end / dt` is at most 1e10 steps.",
        "",
        "## Massless DOFs",
        "",
        "A DOF whose row of `structure.mass` is zero (e.g. a rotation of a lumped-mass FE model)",
        "is condensed out statically (Guyan): with `s` the massless and `m` the other DOFs,",
        "`x_s = -K_ss⁻¹ K_sm x_m`, `K_r = K_mm - K_ms K_ss⁻¹ K_sm`, `M_r = M_mm`, `C_r = Tᵀ C T`",
        "(`vibroimpact.fe.condensation`, sparse). This is exact when the damping on the massless",
        "DOFs is zero, Rayleigh (`αM + βK`) or modal; any other damping acting on them is",
        "neglected in their (static) equations, with a `CondensationWarning`. `K_ss` must be",
        "positive definite (the massless DOFs held by stiffness). A load on a massless DOF",
        "moves it statically (see the next paragraph), and `[initial]` must be 0 there (or the",
        "static value of the others); a gap there has its `hertz` law in series with the DOF's",
        "static compliance (the next paragraph). DOF indices in the file (`dof`,",
        "`output.dofs`, the `[initial]` lists) count",
        "the file's DOFs. The model that runs has the DOFs with mass only, in the same order",
        "(`ModelFile.condensation.retained` maps them back), but its results (`vibroimpact run`,",
        "`ModelFile.simulate`: the `dof` coordinate, the CSV columns `x8 [m]`, `x9 [rad]`, ...)",
        "number the file's DOFs: every DOF, or those of `output.dofs`. A massless DOF there is",
        "recovered from the recorded rows, `x_s = -K_ss⁻¹ K_sm x_m` and its velocity and",
        "acceleration by the same matrix (exact where the condensation is); its peak `|x|` is",
        "taken over the recorded rows (every `output.every`-th step), the other DOFs' over every",
        "step. Each DOF keeps its unit: the rotations of the DOF map (directions 4-6, `rx`,",
        "`ry`, `rz`) are in rad (rad/s, rad/s²), the others in m; results name it per DOF (the",
        "`dof_unit` coordinate, the CSV column headers).",
        "",
        "A mass that is singular without zero rows (the consistent mass of reduced-integration",
        "solids such as CalculiX's C3D20R, of expanded shells such as S8R) has massless modes:",
        "its null space `Z` (eigenvalues of `M` at or below 1e-10 of the largest; an eigenvalue",
        "below -1e-10 of it is refused, naming it) is condensed the same way in the eigenvectors",
        "of `M`, `x = T q` with `T = R - Z (ZᵀKZ)⁻¹ ZᵀKR` (dense, up to 6,000 DOFs), so that the",
        "finite frequencies are exactly those of the FE program. The coordinates `q` are then",
        "generalized: results are recovered on the file's DOFs as above; an `[initial]` state",
        "must have no part in `Z` or be a state `T q` (a mode shape). Every node of such",
        "elements has a part in `Z`. A load there works: it acts on `q` as `Tᵀf F(t)` and the",
        "recovered DOFs include its static part `Z (ZᵀKZ)⁻¹ Zᵀ f F(t)` (exact); one that moves",
        "a gap there statically is refused. A gap there works: the massless modes answer its force",
        "`φ` statically, `u = (Tᵀb)ᵀq + c φ` with `c = bᵀ Z (ZᵀKZ)⁻¹ Zᵀ b`, so its law (`hertz`",
        "only, any exponent) runs in series with a spring of compliance `c` (`law.compliance`),",
        "exactly, and the recovered DOFs and penetration include the contact's static part",
        "(docs/beam.md, Gaps on massless DOFs and modes).",
        "",
    ]
    out += _methods_section()
    out += [
        "## Contact laws",
        "",
        "| kind | parameters |",
        "|---|---|",
    ]
    for kind in _LAW_KINDS:
        params = [name for name, kinds in _LAW_FIELDS.items() if kind in kinds]
        out.append(f"| `{kind}` | {', '.join(f'`{p}`' for p in params)} |")
    out += [
        "",
        "The formulas and sources are in the docstrings of `vibroimpact.contact`.",
        "",
        "## Mistakes",
        "",
        "Every mistake of a file is reported before anything runs, all together, one line each,",
        "naming the key, the value and what was expected; `vibroimpact run` then exits with",
        "code 2. For example:",
        "",
        "<!-- fragment: what three bad model files print (vibroimpact run exits with 2) -->",
        "```text",
        "gaps[0].law.restitution: 1.2 is not valid; expected a number with 0 <= restitution <= 1",
        "gaps[0].clearence: unknown key; did you mean 'clearance'? expected one of: dof, "
        "coefficients, clearance, side, name, law",
        "solver.dt: missing; expected a number > 0 in s",
        "```",
        "",
        "Several keys of one table found in another (or at the top level) are one line saying",
        "where they belong, as when a header is missing:",
        "",
        "<!-- fragment: what tests/bad_models/structure_header_missing.toml prints -->",
        "```text",
        "structure: kind, mass, stiffness, damping belong in [structure]: is its header missing?"
        " expected them under the header [structure]",
        "```",
        "",
    ]
    return "\n".join(out)
