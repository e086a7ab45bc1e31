"""The contact laws are data of the core (issue 19, item 4): every law of the core's catalog
(``_core.law_catalog()``) has its Python class, its model-file schema entry and its docs page, all
derived from that list, and every default Python shows (dataclass, signature, repr, schema, docs)
is the core's."""

from __future__ import annotations

import ast
import dataclasses
import inspect
import math
import re
from pathlib import Path
from typing import Any

import pytest
import vibroimpact as vi
from vibroimpact import _core, contact
from vibroimpact import docs as docs_generator
from vibroimpact.errors import ModelError
from vibroimpact.io import model_file

CATALOG = _core.law_catalog()
KINDS = [e["name"] for e in CATALOG]
DOCS = Path(__file__).resolve().parents[1] / "docs"

#: A valid value of every parameter of the catalog (for building each law from required ones).
VALID: dict[str, Any] = {
    "stiffness": 2.0e9,
    "restitution": 0.6,
    "damping": 40.0,
    "loading_penetration": [0.0, 1e-5, 2e-5],
    "loading_force": [0.0, 10.0, 30.0],
    "unloading_penetration": [0.0, 1e-5, 2e-5],
    "unloading_force": [0.0, 5.0, 30.0],
}


def _entry(kind: str) -> dict[str, Any]:
    return next(e for e in CATALOG if e["name"] == kind)


def _required(entry: dict[str, Any]) -> dict[str, Any]:
    """The required parameters of a law, and the first of its alternatives."""
    params = {p["name"]: VALID[p["name"]] for p in entry["parameters"] if p["required"]}
    optional = [p["name"] for p in entry["parameters"]
                if not p["required"] and p["default"] is None]
    if optional:
        params[optional[0]] = VALID[optional[0]]
    return params


def test_the_python_laws_are_the_catalog_in_its_order() -> None:
    assert list(contact.LAWS) == KINDS
    assert list(contact.FORCE_LAWS) == [e["name"] for e in CATALOG if e["family"] != "rigid"]
    assert contact.RESTITUTION_LAWS == tuple(
        e["name"] for e in CATALOG if e["family"] == "hysteretic"
        and any(p["name"] == "restitution" and p["required"] for p in e["parameters"]))


@pytest.mark.parametrize("kind", KINDS)
def test_every_law_has_its_class_with_the_cores_parameters_and_defaults(kind: str) -> None:
    entry = _entry(kind)
    cls = contact.LAWS[kind]
    assert cls.kind == kind
    assert cls.__name__ == entry["class_name"]
    assert getattr(vi.contact, entry["class_name"]) is cls
    assert entry["class_name"] in contact.__all__
    assert cls.__module__ == "vibroimpact.contact"
    fields = [f for f in dataclasses.fields(cls) if f.init]
    assert [f.name for f in fields] == [p["name"] for p in entry["parameters"]]
    signature = inspect.signature(cls).parameters
    law = cls(**_required(entry))
    for f, p in zip(fields, entry["parameters"], strict=True):
        if p["default"] is not None:  # a default: the core's, in the class, signature and repr
            assert f.default == p["default"] and type(f.default) is float, p["name"]
            assert signature[p["name"]].default == p["default"]
            assert f"{p['name']}={p['default']!r}" in repr(law)
        else:  # required or an alternative: no value of Python's own
            assert f.default in (dataclasses.MISSING, None), p["name"]
        if p["required"]:
            params = _required(entry)
            del params[p["name"]]
            with pytest.raises((ModelError, TypeError), match=p["name"]):
                cls(**params)
    if entry["doc"]:  # a generated class: its documentation is the core's
        assert inspect.cleandoc(cls.__doc__ or "") == entry["doc"]
    else:
        assert cls.__doc__ and not cls.__doc__.startswith(cls.__name__ + "(")


def test_a_generated_class_has_a_signature_help_and_pickles() -> None:
    import pickle
    import pydoc

    cls = vi.contact.LankaraniNikravesh
    assert str(inspect.signature(cls)) == (
        "(stiffness: 'float | Geometry', exponent: 'float' = 1.5, "
        "restitution: 'float | None' = None) -> None")
    assert "Lankarani & Nikravesh 1990" in pydoc.render_doc(cls)
    law = cls(stiffness=1.5e11, exponent=1.5, restitution=0.9)
    assert pickle.loads(pickle.dumps(law)) == law
    assert dataclasses.is_dataclass(law)
    with pytest.raises(dataclasses.FrozenInstanceError):
        law.restitution = 0.5  # type: ignore[misc]


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "rigid"])
def test_the_cores_defaults_are_the_ones_it_applies(kind: str) -> None:
    """A spec without the parameters that have a default gives the same force as one with the
    catalog's defaults written out: the core builds its laws with the defaults it publishes."""
    entry = _entry(kind)
    given = {"kind": kind, **_required(entry)}
    full = {**given, **{p["name"]: p["default"] for p in entry["parameters"]
                        if p["default"] is not None}}
    states = (1.5e-5, -0.002, 0.4, 2e-5)  # in tabulated's reversal band
    assert _core.contact_force(given, *states) == _core.contact_force(full, *states)
    # and a value other than the default changes the force, so the check above can fail
    for p in entry["parameters"]:
        if p["default"] is not None and not (kind == "kelvin-voigt" and p["name"] == "exponent"):
            other = {**full, p["name"]: p["default"] * 1.1 if p["default"] else 1e-9}
            assert _core.contact_force(other, *states) != _core.contact_force(full, *states)


def _law_field(param: str) -> model_file.Field:
    return next(f for f in model_file.SCHEMA if f.path == f"gaps[].law.{param}")


def test_the_model_file_schema_has_every_law_and_parameter() -> None:
    assert _law_field("kind").choices == tuple(KINDS)
    reference = model_file.render_reference()
    for entry in CATALOG:
        kind = entry["name"]
        assert re.search(rf"^\| `{re.escape(kind)}` \| .+ \|$", reference, re.M), kind
        for p in entry["parameters"]:
            f = _law_field(p["name"])
            assert f.when is not None and kind in f.when[1], (kind, p["name"])
            if p["required"] and p["name"] != "stiffness":  # stiffness: or give geometry
                assert f.default is model_file.REQUIRED or (
                    f.required_when is not None and kind in f.required_when[1]), (kind, p["name"])
            elif p["default"] is None and not p["required"]:
                alternatives = [r for r in model_file.RULES
                                if r.when == ("kind", (kind,)) and p["name"] in r.keys]
                assert alternatives, (kind, p["name"])
            if p["default"] is not None:  # the default the reference shows is the core's
                shown = f.default_text or str(f.default)
                assert f"{p['default']:g}" in shown, (kind, p["name"], shown)


def test_the_model_file_loads_every_law_with_the_cores_defaults(tmp_path: Path) -> None:
    for entry in CATALOG:
        if entry["family"] == "rigid":
            continue
        params = _required(entry)
        law = "\n".join(f"{k} = {v!r}" for k, v in params.items())
        text = (f'schema_version = 1\n[structure]\nkind = "sdof"\nmass = 1.0\n'
                f'[[gaps]]\ndof = 0\n[gaps.law]\nkind = "{entry["name"]}"\n{law}\n'
                '[solver]\ndt = 1e-6\nt_end = 1e-5\n')
        path = tmp_path / f"{entry['name']}.toml"
        path.write_text(text, encoding="utf-8")
        loaded = vi.io.load_model(path).model.gaps[0].law
        assert loaded == contact.LAWS[entry["name"]](**params)


def test_every_law_has_its_docs_page_with_the_cores_parameters() -> None:
    assert {p.stem for p in (DOCS / "laws").glob("*.md")} == set(KINDS)
    for entry in CATALOG:
        page = (DOCS / "laws" / f"{entry['name']}.md").read_text(encoding="utf-8")
        assert page == docs_generator.law_page(entry["name"]), \
            "run: python -m vibroimpact.docs"
        for p in entry["parameters"]:
            row = next(line for line in page.splitlines() if line.startswith(f"| `{p['name']}` |"))
            default = row.split("|")[2].strip()
            if p["default"] is not None:
                assert default == f"`{p['default']!r}`", row
            else:
                assert default == "required" if p["required"] else default.startswith("one of")


def test_the_table_of_the_laws_is_generated_from_the_catalog() -> None:
    text = (DOCS / "contact-laws.md").read_text(encoding="utf-8")
    assert text == docs_generator.contact_laws_page(text), \
        "run: python -m vibroimpact.docs"
    table = docs_generator.law_table()
    for entry in CATALOG:
        if entry["family"] != "rigid":
            assert f"| [`{entry['name']}`](laws/{entry['name']}.md) | {entry['source']} | " in table


def test_a_new_hysteretic_entry_needs_nothing_else(monkeypatch: pytest.MonkeyPatch) -> None:
    """What a new hysteretic law of the core gets without any edit in Python: its class, its
    schema conditions and its row of the docs table (an entry made from flores's)."""
    new = {**_entry("flores"), "name": "new-law", "class_name": "NewLaw",
           "doc": "A new law: ``χ = 8(1 − ce)/(5 ce)``.", "source": "Somebody (2030)"}
    cls = contact._hysteretic_class(new)
    assert cls.__name__ == "NewLaw" and cls.kind == "new-law"
    assert inspect.signature(cls) == inspect.signature(contact.LAWS["flores"])
    monkeypatch.setitem(contact.CATALOG, "new-law", new)
    # the core would check its parameters as flores's, the entry it is made from
    accepts = _core.law_parameter_accepts
    monkeypatch.setattr(_core, "law_parameter_accepts", lambda kind, name, value: accepts(
        "flores" if kind == "new-law" else kind, name, value))
    assert cls(stiffness=1e9, restitution=0.5).to_spec()["kind"] == "new-law"
    monkeypatch.setitem(contact.FORCE_LAWS, "new-law", cls)
    assert "new-law" in model_file._kinds_requiring("restitution")
    assert model_file._law_fields()["exponent"]["new-law"] == 1.5
    assert "| [`new-law`](laws/new-law.md) | Somebody (2030) |" in docs_generator.law_table()


def test_no_generated_law_is_written_in_python() -> None:
    """The hysteretic laws exist in Python only as generated classes: contact.py defines no class
    of theirs and lists none of their names in ``__all__`` by hand."""
    source = Path(contact.__file__).read_text(encoding="utf-8")
    tree = ast.parse(source)
    defined = {n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)}
    literal_all = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                       and any(getattr(t, "id", "") == "__all__" for t in n.targets))
    for cls in contact.HYSTERETIC_CLASSES:
        assert cls.__name__ not in defined and cls.__name__ not in literal_all
    assert {c.kind for c in contact.HYSTERETIC_CLASSES} == {
        e["name"] for e in CATALOG if e["doc"]}


def test_hunt_crossley_takes_one_of_its_alternatives_in_the_core() -> None:
    spec = {"kind": "hunt-crossley", "stiffness": 1e9, "restitution": 0.5, "damping": 10.0}
    with pytest.raises(_core.ModelError, match="hunt-crossley: damping is not valid; expected "
                       "exactly one of restitution or damping"):
        _core.contact_force(spec, 1e-5, 0.1, 0.3)
    f, _, _ = _core.contact_force({**spec, "damping": None}, 1e-5, 0.1, 0.3)
    assert math.isclose(f, 1e9 * 1e-5 ** 1.5 * (1 + 0.75 * 0.1 / 0.3), rel_tol=1e-14)
    b, _, _ = _core.contact_force({**spec, "restitution": None}, 1e-5, 0.1, 0.3)
    assert math.isclose(b, 1e9 * 1e-5 ** 1.5 + 10.0 * 1e-5 ** 1.5 * 0.1, rel_tol=1e-14)


#: Values each number parameter is probed with: both sides of the ranges the laws check (0, 1),
#: inside and beyond them, and the non-finite numbers.
PROBES = (0.0, -1.0, 0.5, 1.0, 1.5, math.nan, math.inf)


@pytest.mark.parametrize("kind", KINDS)
def test_python_refuses_exactly_what_the_core_refuses(kind: str) -> None:
    """For every number parameter of every law and each probe, the Python class refuses the value
    exactly when the core's constructor (``Law::from_parameters``, through
    ``_core.contact_force``) does, which is what ``_core.law_parameter_accepts`` says, and words
    the refusal with the catalog's ``expected``: a check that drifts on either side fails here."""
    entry = _entry(kind)
    refused = []
    for p in entry["parameters"]:
        if p["list"]:
            continue
        name = p["name"]
        for value in PROBES:
            params = {**_required(entry), name: value}
            alternatives = {"restitution": "damping", "damping": "restitution"}
            if kind == "hunt-crossley" and name in alternatives:  # the other is left out
                params.pop(alternatives[name], None)
            try:
                _core.contact_force({"kind": kind, **params}, 1e-6, 0.0, 1.0)
                core_refuses = False
            except _core.ModelError as e:
                core_refuses = True
                assert f"{kind}: {name} = " in str(e) and p["expected"] in str(e), str(e)
            assert _core.law_parameter_accepts(kind, name, value) == (not core_refuses)
            try:
                contact.LAWS[kind](**params)
                python_refuses = False
            except ModelError as e:
                python_refuses = True
                assert str(e) == (f"law.{name}: {value!r} is not valid; "
                                  f"expected {p['expected']}"), str(e)
            assert python_refuses == core_refuses, (kind, name, value)
            refused.append(core_refuses)
    # every law refuses some probe and takes some: the comparison above can fail both ways
    assert any(refused) and not all(refused)


def test_the_model_file_schema_takes_every_value_the_core_takes(tmp_path: Path) -> None:
    """The schema's range of a law parameter spans every kind that has it (each kind's own range
    is checked by its class, i.e. by the core): the file reader never refuses a value the core
    takes, such as the rigid law's restitution 0 (a plastic impact)."""
    for entry in CATALOG:
        for p in entry["parameters"]:
            if p["list"]:
                continue
            field = _law_field(p["name"])
            for value in PROBES:
                if _core.law_parameter_accepts(entry["name"], p["name"], value):
                    assert field.in_range(value), (entry["name"], p["name"], value)
    path = tmp_path / "plastic.toml"
    path.write_text('[structure]\nkind = "sdof"\nmass = 1.0\nstiffness = 100.0\n'
                    '[[gaps]]\ndof = 0\nclearance = 0.01\n'
                    '[gaps.law]\nkind = "rigid"\nrestitution = 0.0\n'
                    '[solver]\nmethod = "event-driven"\nt_end = 1.0\ndt = 1e-3\n')
    assert model_file.load_model(path).model.gaps[0].law.restitution == 0.0


def _refusals(spec: dict[str, Any], build: Any) -> tuple[str | None, str | None]:
    """What the core (``_core.contact_force``) and Python (``build()``) say of ``spec``: each
    message, ``None`` when it is taken."""
    said: list[str | None] = []
    for attempt, error in ((lambda: _core.contact_force(spec, 1e-6, 0.0, 1.0), _core.ModelError),
                           (build, ModelError)):
        try:
            attempt()
            said.append(None)
        except error as e:
            said.append(str(e))
    return said[0], said[1]


@pytest.mark.parametrize(("given", "field"), [
    ({"restitution": 0.5, "damping": 10.0}, "damping"),
    ({}, "restitution"),
    ({"restitution": 0.5}, None),
    ({"damping": 10.0}, None),
])
def test_python_and_the_core_refuse_the_same_hunt_crossley_alternatives(
    given: dict[str, float], field: str | None
) -> None:
    """Exactly one of restitution or damping: the rule is the core's
    (``_core.law_alternatives_fault``), worded once."""
    core, python = _refusals({"kind": "hunt-crossley", "stiffness": 1e9, **given},
                             lambda: contact.HuntCrossley(stiffness=1e9, **given))
    if field is None:
        assert core is None and python is None
        return
    expected = "expected exactly one of restitution or damping"
    assert core == f"hunt-crossley: {field} is not valid; {expected}"
    assert python == f"law.{field}: {given.get(field)!r} is not valid; {expected}"


#: Malformed tabulated curves: the parameters changed from VALID and the one to be named.
BAD_CURVES = [
    ({"loading_penetration": [0.0]}, "loading_penetration"),
    ({"loading_force": [0.0, 10.0]}, "loading_force"),
    ({"unloading_penetration": [1e-6, 1e-5, 2e-5]}, "unloading_penetration"),
    ({"loading_force": [1.0, 10.0, 30.0]}, "loading_force"),
    ({"loading_penetration": [0.0, 2e-5, 1e-5]}, "loading_penetration"),
    ({"loading_penetration": [0.0, 1e-5, math.inf]}, "loading_penetration"),
    ({"unloading_force": [0.0, 5.0, math.nan]}, "unloading_force"),
    ({"loading_force": [0.0, 30.0, 10.0]}, "loading_force"),
    ({"loading_force": [0.0, 30.0, 30.0]}, "loading_force"),
]


@pytest.mark.parametrize(("change", "field"), BAD_CURVES)
def test_python_and_the_core_refuse_the_same_malformed_curves(
    change: dict[str, list[float]], field: str
) -> None:
    """The curve shape is the core's rule (``_core.tabulated_curve_fault``): both sides name the
    same parameter with the same expected words."""
    curves = {k: v for k, v in VALID.items() if k.endswith(("_penetration", "_force"))}
    curves.update(change)
    core, python = _refusals({"kind": "tabulated", **curves},
                             lambda: contact.Tabulated(**curves))
    assert core is not None and python is not None
    _, expected = python.split("; expected ", 1)
    assert python.startswith(f"law.{field}: {curves[field]!r} is not valid; ")
    assert core.startswith(f"tabulated: {field} = ") and core.endswith(f"; expected {expected}")
