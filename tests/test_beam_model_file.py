"""Beams in model files: ``[structure] kind = "beam"``, gaps by node or position, loads on node
sets, and the one-line errors naming the TOML path."""

from __future__ import annotations

import copy
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
import vibroimpact as vi
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from vibroimpact.cli import main as cli_main
from vibroimpact.fe import (
    Beam,
    Material,
    PointMass,
    Rayleigh,
    Section,
    Spring,
    Support,
    modes,
)
from vibroimpact.io import ModelFileError, load_model

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

BASE = tomllib.loads("""
[structure]
kind = "beam"
length = 1.0
elements = 20
[structure.section]
kind = "tube"
outer_diameter = 0.19
wall_thickness = 0.005
[structure.material]
youngs_modulus = 207e9
poisson = 0.3
density = 34410.0
[[gaps]]
node = "end"
clearance = 0.003
side = "both"
[gaps.law]
kind = "hertz"
stiffness = 1.5e11
[[loads]]
kind = "harmonic"
nodes = "all"
amplitude = 100.0
frequency = 10.0
[solver]
dt = 1e-5
t_end = 0.01
""")


def write(tmp_path: Path, change: Callable[[dict[str, Any]], Any] | None = None) -> Path:
    doc = copy.deepcopy(BASE)
    if change is not None:
        change(doc)
    path = tmp_path / "beam.toml"
    path.write_text(tomli_w.dumps(doc), encoding="utf-8")
    return path


def errors(tmp_path: Path, change: Callable[[dict[str, Any]], Any]) -> list[str]:
    with pytest.raises(ModelFileError) as info:
        load_model(write(tmp_path, change))
    return info.value.errors


def test_a_full_beam_file_builds_the_api_beam(tmp_path: Path) -> None:
    def change(d: dict[str, Any]) -> None:
        s = d["structure"]
        s.update(theory="euler-bernoulli", lumped_mass=True, rotary_inertia=True)
        s["section"] = {"kind": "circle", "diameter": 0.05}
        s["supports"] = [{"node": "start", "kind": "pinned"}, {"at": 1.0, "directions": ["x"]}]
        s["springs"] = [{"node": 10, "direction": "ry", "stiffness": 1e4}]
        s["masses"] = [{"at": 0.5, "mass": 2.0, "rotary_inertia": 0.01}]
        s["damping"] = {"kind": "rayleigh", "frequencies": [50.0, 500.0], "ratios": [0.02, 0.02]}
        d["gaps"] = [dict(d["gaps"][0], node=None, at=0.25, direction="x")]
        del d["gaps"][0]["node"]
        d["loads"][0]["nodes"] = ["middle", 3]

    mf = load_model(write(tmp_path, change))
    beam = Beam(1.0, 20, Section.circle(0.05), Material(207e9, 0.3, 34410.0),
                theory="euler-bernoulli", lumped_mass=True, rotary_inertia=True,
                supports=[Support(node="start", kind="pinned"), Support(at=1.0, directions=["x"])],
                springs=[Spring(1e4, direction="ry", node=10)],
                masses=[PointMass(2.0, at=0.5, rotary_inertia=0.01)],
                damping=Rayleigh.from_frequencies(50.0, 500.0, 0.02, 0.02))
    for name in ("mass", "stiffness", "damping"):
        np.testing.assert_array_equal(getattr(mf.model.structure, name).toarray(),
                                      getattr(beam.structure, name).toarray())
    assert mf.model.gaps[0].dof == beam.dof(at=0.25, direction="x")
    assert mf.model.loads[0].dofs == (beam.dof(node=10), beam.dof(node=3))
    assert mf.beam is not None and mf.beam.dof_map == beam.dof_map
    assert mf.simulate().complete


@pytest.mark.parametrize(
    ("section", "expected"),
    [
        ({"kind": "tube", "outer_diameter": 0.19, "inner_diameter": 0.18},
         Section.tube(0.19, inner_diameter=0.18)),
        ({"kind": "rectangle", "size_x": 0.04, "size_y": 0.02}, Section.rectangle(0.04, 0.02)),
        ({"kind": "user", "area": 2.9e-3, "second_moment": 1.2e-5, "shear_coefficient": 0.53,
          "torsion_constant": 2.4e-5}, Section.user(2.9e-3, 1.2e-5, shear_coefficient=0.53,
                                                    torsion_constant=2.4e-5)),
    ],
)
def test_sections(tmp_path: Path, section: dict[str, Any], expected: Section) -> None:
    mf = load_model(write(tmp_path, lambda d: d["structure"].update(section=section,
                                                                      dofs_per_node=6)))
    assert mf.beam is not None and mf.beam.section == expected
    assert mf.model.n_dof == 21 * 6


def test_modal_damping_in_a_file(tmp_path: Path) -> None:
    mf = load_model(write(tmp_path, lambda d: d["structure"].update(
        damping={"kind": "modal", "ratios": [0.01, 0.02]})))
    m = modes(mf.beam, 3)
    phi, w = m.elastic_shapes, 2 * np.pi * m.elastic_frequencies_hz
    z = np.diag(phi.T @ mf.model.structure.damping @ phi) / (2 * w)
    np.testing.assert_allclose(z, [0.01, 0.02, 0.02], rtol=1e-6)


BAD = [
    ("section_kind", lambda d: d["structure"]["section"].update(kind="hex"),
     ["structure.section.kind: 'hex' is not valid; expected one of \"circle\", \"tube\", "
      "\"rectangle\", \"user\""]),
    ("section_missing", lambda d: d["structure"].pop("section"),
     ["structure.section: missing; expected a table [structure.section]"]),
    ("tube_both", lambda d: d["structure"]["section"].update(inner_diameter=0.18),
     ["structure.section.inner_diameter: 0.18 is not valid; expected exactly one of "
      "wall_thickness or inner_diameter for kind = \"tube\", not both"]),
    ("tube_too_thick", lambda d: d["structure"]["section"].update(wall_thickness=0.2),
     ["structure.section.wall_thickness: 0.2 is not valid; expected a thickness <= "
      "outer_diameter / 2 = 0.095 m"]),
    ("tube_absurd", lambda d: d["structure"]["section"].update(outer_diameter=1.16e77),
     ["structure.section.outer_diameter: 1.16e+77 is not valid; expected a size in m <= 1e+60 "
      "(its fourth power must be a finite number)"]),
    ("poisson", lambda d: d["structure"]["material"].update(poisson=0.6),
     ["structure.material.poisson: 0.6 is not valid; expected a number with -1 < poisson < 0.5"]),
    ("elements", lambda d: d["structure"].update(elements=1.5),
     ["structure.elements: 1.5 is not valid; expected an integer with 1 <= elements <= 1000"]),
    ("lumped_string", lambda d: d["structure"].update(lumped_mass="yes"),
     ["structure.lumped_mass: 'yes' is not valid; expected true or false"]),
    ("gap_between_nodes", lambda d: d["gaps"][0].pop("node") and d["gaps"][0].update(at=0.33),
     ["gaps[0].at: 0.33 is not valid; expected a point at a node (the nearest nodes are 6 at "
      "0.3 and 7 at 0.35 of the length; change elements or the position)"]),
    ("gap_node_name", lambda d: d["gaps"][0].update(node="top"),
     ["gaps[0].node: 'top' is not valid; expected a node index (integer >= 0) or \"start\", "
      "\"middle\", \"end\""]),
    ("gap_node_range", lambda d: d["gaps"][0].update(node=99),
     ["gaps[0].node: 99 is not valid; expected a node index 0 .. 20 or one of \"start\", "
      "\"middle\", \"end\""]),
    ("gap_dof_and_node", lambda d: d["gaps"][0].update(dof=3),
     ["gaps[0].node: 'end' is not valid; expected exactly one of dof or node or at, not both"]),
    ("gap_unplaced", lambda d: d["gaps"][0].pop("node"),
     ["gaps[0].dof: missing; expected exactly one of dof or node or at for a beam"]),
    ("gap_direction_planar", lambda d: d["gaps"][0].update(direction="y"),
     ["gaps[0].direction: 'y' is not valid; expected one of x, ry (a planar beam; use "
      "dofs_per_node = 4 for a rotor, 6 for 3-D)"]),
    ("gap_on_fixed_dof",
     lambda d: d["structure"].update(supports=[{"node": "end", "kind": "pinned"}]),
     ["gaps[0].direction: 'x' is not valid at node 20; expected a DOF that no support fixes"]),
    ("load_nodes_word", lambda d: d["loads"][0].update(nodes="some"),
     ["loads[0].nodes: 'some' is not valid; expected \"all\", a node (index or \"start\", "
      "\"middle\", \"end\") or a list of nodes"]),
    ("load_nodes_range", lambda d: d["loads"][0].update(nodes=[0, 25]),
     ["loads[0].nodes: 25 is not valid; expected a node index 0 .. 20 or one of \"start\", "
      "\"middle\", \"end\""]),
    ("support_node_and_at", lambda d: d["structure"].update(supports=[{"node": 0, "at": 0.0}]),
     ["structure.supports[0].at: 0.0 is not valid; expected exactly one of node or at, not "
      "both"]),
    ("support_direction",
     lambda d: d["structure"].update(supports=[{"node": 0, "directions": ["q"]}]),
     ["structure.supports[0].directions: 'q' is not valid; expected one of x, ry (a planar "
      "beam; use dofs_per_node = 4 for a rotor, 6 for 3-D)"]),
    ("modal_without_ratios", lambda d: d["structure"].update(damping={"kind": "modal"}),
     ["structure.damping.ratios: missing; expected a non-empty list of numbers"]),
    ("user_without_kappa", lambda d: d["structure"].update(
        section={"kind": "user", "area": 1e-3, "second_moment": 1e-6}),
     ["structure.section.shear_coefficient: missing; expected a number > 0 for a user section "
      "with theory = \"timoshenko\""]),
    ("node_on_sdof", lambda d: d.update(structure={"kind": "sdof", "mass": 1.0}),
     ["gaps[0].node: 'end' is not valid; expected no node when structure.kind = \"sdof\" (it "
      "applies to structure.kind = \"beam\" | \"matrices\")",
      "gaps[0].dof: missing; expected a DOF index (integer >= 0) or a non-empty list of them",
      "loads[0].nodes: 'all' is not valid; expected no nodes when structure.kind = \"sdof\" (it "
      "applies to structure.kind = \"beam\" | \"matrices\")",
      "loads[0].dof: missing; expected a DOF index (integer >= 0) or a non-empty list of them"]),
]


@pytest.mark.parametrize(("name", "change", "expected"), BAD, ids=[b[0] for b in BAD])
def test_beam_mistakes_are_one_line_each_naming_the_path(
    tmp_path: Path, name: str, change: Callable[[dict[str, Any]], Any], expected: list[str]
) -> None:
    assert errors(tmp_path, change) == expected


def test_beam_mistakes_on_the_command_line(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, lambda d: d["gaps"][0].update(node=99))
    assert cli_main(["run", str(path)]) == 2
    assert capsys.readouterr().err.strip() == (
        "vibroimpact: error: gaps[0].node: 99 is not valid; expected a node index 0 .. 20 or "
        "one of \"start\", \"middle\", \"end\""
    )


def test_run_a_beam_file(tmp_path: Path) -> None:
    mf = load_model(write(tmp_path))
    assert mf.model.n_dof == 42 and mf.model.gaps[0].dof == 40
    assert mf.model.loads[0].dofs == tuple(range(0, 42, 2))
    r = mf.simulate()
    assert isinstance(r, vi.Result) and r.complete


# ------------------------------------------------------------------------------------------
# Property: a mutated beam file gives a model or ModelFileErrors, never another exception
# ------------------------------------------------------------------------------------------

_EXAMPLE = tomllib.loads(
    (Path(__file__).resolve().parents[1] / "examples" / "models" / "hollow_shaft.toml")
    .read_text(encoding="utf-8")
)
_VALUES = st.one_of(
    st.integers(-3, 30), st.floats(allow_nan=False), st.booleans(),
    st.sampled_from(["start", "middle", "end", "all", "x", "ry", "y", "tube", "circle", "user",
                     "rectangle", "fixed", "pinned", "modal", "rayleigh", "beam", ""]),
    st.lists(st.one_of(st.integers(-1, 25), st.sampled_from(["start", "end", "x"])), max_size=3),
    st.fixed_dictionaries({"node": st.integers(-1, 25)}),
)
_KEYS = st.sampled_from(["node", "at", "nodes", "direction", "dof", "kind", "supports",
                         "springs", "masses", "damping", "section", "elements", "ratios",
                         "directions", "stiffness", "mass", "wall_thickness", "inner_diameter"])


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*prefix, i))
    return out


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_mutated_beam_files_give_only_model_file_errors(data: st.DataObject,
                                                        tmp_path: Path) -> None:
    doc = copy.deepcopy(_EXAMPLE)
    doc["solver"]["t_end"] = 1e-4
    for _ in range(data.draw(st.integers(1, 3))):
        *parents, last = data.draw(st.sampled_from(_paths(doc)))
        node: Any = doc
        for p in parents:
            node = node[p]
        action = data.draw(st.sampled_from(["replace", "delete", "add"]))
        if action == "delete" and isinstance(node, dict):
            del node[last]
        elif action == "add" and isinstance(node, dict):
            node[data.draw(_KEYS)] = data.draw(_VALUES)
        else:
            node[last] = data.draw(_VALUES)
    path = tmp_path / "m.toml"
    path.write_text(tomli_w.dumps(doc), encoding="utf-8")
    try:
        load_model(path)
    except ModelFileError as e:
        assert e.errors
        for line in e.errors:
            assert line and "\n" not in line and ": " in line and "expected" in line


def test_an_absurd_beam_length_is_a_model_error_not_an_overflow() -> None:
    """A length whose L³ overflows (found by the mutation test above) is reported on
    structure.length with what was expected, not as Python's OverflowError."""
    from vibroimpact.fe import Beam, Material, Section

    with pytest.raises(vi.ModelError, match=r"^structure\.length: 1\.1e\+104 m .*expected"):
        Beam(length=1.1e104, elements=4,
             section=Section.tube(outer_diameter=0.19, wall_thickness=0.005),
             material=Material(youngs_modulus=207e9, poisson=0.3, density=7800.0))
