"""The methods are data of the core (issue 19, items 2 and 3): every method of the core's catalog
(``_core.method_catalog()``) is the integrator of that name, whose defaults are the core's and
whose checks run in the core; every run (the API, model files, sweeps) hands the core the same
typed ``MethodSpec``. With the laws' catalog (tests/test_law_catalog.py): every default Python
shows, in the docs, the model-file schema and the dataclasses, is the core's."""

from __future__ import annotations

import dataclasses
import inspect
import pickle
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact import _core, contact, integrators
from vibroimpact import docs as generated_docs
from vibroimpact.errors import ModelError
from vibroimpact.io import model_file
from vibroimpact.simulate import _run_core
from vibroimpact.sweeps import Param, Sweep, run_sweep
from vibroimpact.sweeps.runner import _plan

DOCS = Path(__file__).resolve().parents[1] / "docs"
METHODS = integrators.CATALOG["methods"]
NAMES = [m["name"] for m in METHODS]
_TYPES = {"number": float, "integer": int, "flag": bool}


def _section(page: str, title: str) -> str:
    """The part of a generated page from heading ``title`` to the next heading of its level."""
    start = page.index(title)
    end = page.find("\n## ", start + len(title))
    return page[start:] if end < 0 else page[start:end]


def _docs_default(section: str, name: str) -> str:
    """The default a generated docs table shows for parameter ``name``."""
    row = next(line for line in section.splitlines() if line.startswith(f"| `{name}` |"))
    return row.split("|")[2].strip()


def _cases() -> list[tuple[str, str]]:
    return ([("method", n) for n in NAMES] + [("settings", "newton"), ("settings", "adaptive")]
            + [("law", k) for k in contact.LAWS] + [("model", p) for p in vi.model.MODEL_CATALOG])


#: A valid instance of the class of each part of the model's catalog, and the table of the
#: model file (its schema path and its docs section) that holds the part's fields.
_MODEL_PARTS: dict[str, tuple[Any, str, str]] = {
    "structure": (lambda: vi.Structure([[1.0]]), "structure", "## `[structure]`"),
    "gap": (lambda: vi.Gap(dof=0, law=contact.Hertz(stiffness=1e9)), "gaps[]",
            "## `[[gaps]]`"),
    "radial-gap": (lambda: vi.model.RadialGap(dof=[0, 1], law=contact.Hertz(stiffness=1e9)),
                   "gaps[]", "## `[[gaps]]`"),
    "load.constant": (lambda: vi.ConstantLoad(dof=0, amplitude=1.0), "loads[]",
                      "## `[[loads]]`"),
    "load.harmonic": (lambda: vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=2.0), "loads[]",
                      "## `[[loads]]`"),
    "load.table": (lambda: vi.TableLoad(dof=0, time=[0.0, 1.0], force=[0.0, 1.0]), "loads[]",
                   "## `[[loads]]`"),
    "load.unbalance": (lambda: vi.UnbalanceLoad(dof=[0, 1], magnitude=1e-3), "loads[]",
                       "## `[[loads]]`"),
}


def _model_part_defaults(part: str) -> None:
    """The defaults and choices of the fields of a part of the model (its structure's spin, a
    gap, a radial gap, each kind of load) in the Python class (field, signature, repr), the
    model-file schema and docs/model-file.md are the core's (``_core.model_catalog()``)."""
    build, table, title = _MODEL_PARTS[part]
    instance = build()
    cls = type(instance)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    signature = inspect.signature(cls).parameters
    schema = {f.path: f for f in model_file.SCHEMA}
    docs = _section((DOCS / "model-file.md").read_text(encoding="utf-8"), title)
    for name, f in vi.model.MODEL_CATALOG[part].items():
        core = f["default"]
        entry = schema[f"{table}.{name}"]
        assert list(entry.choices) == f["choices"], (part, name)
        if core is None:  # required (or with the settings that use it): no value of its own
            assert entry.default in (model_file.REQUIRED, None), (part, name)
            assert signature[name].default in (inspect.Parameter.empty, None), (part, name)
            continue
        shown = tuple(core) if isinstance(core, list) else core
        assert getattr(instance, name) == shown, (part, name)
        assert f"{name}={shown!r}" in repr(instance), (part, name)
        assert signature[name].default == shown, (part, name)
        if cls is not vi.Structure:  # its fields are set by its __init__
            assert fields[name].default == shown, (part, name)
        assert entry.default == core and type(entry.default) is type(core), (part, name)
        row = next(line for line in docs.splitlines() if line.startswith(f"| `{name}` |"))
        assert row.split("|")[4].strip() == f"`{model_file._toml(core)}`", (part, name)
    if part == "structure":  # a beam rotor's speed too
        beam = {f.name: f for f in dataclasses.fields(vi.fe.beam.Beam)}
        assert beam["spin_speed"].default == vi.model.model_default(part, "spin_speed")


@pytest.mark.parametrize(("group", "name"), _cases())
def test_every_default_python_shows_is_the_cores(group: str, name: str) -> None:
    """Dataclass field, signature and repr, the model-file schema and its reference, and the
    docs page of every method, of Newton and adaptive stepping, of every law and of every part
    of the model."""
    if group == "model":
        _model_part_defaults(name)
        return
    integrators_page = (DOCS / "integrators.md").read_text(encoding="utf-8")
    reference = model_file.render_reference()
    if group == "law":
        entry = contact.CATALOG[name]
        cls: type = contact.LAWS[name]
        settings = entry["parameters"]
        docs = (DOCS / "laws" / f"{name}.md").read_text(encoding="utf-8")
        instance = cls(**{p["name"]: _valid_law_value(p["name"]) for p in settings
                          if p["required"]} | _one_alternative(settings))
        schema = {p: kinds[name] for p, kinds in model_file._law_fields().items() if name in kinds}
    elif group == "settings":
        cls = integrators.NewtonOptions if name == "newton" else integrators.Adaptive
        settings = integrators.CATALOG[name]
        docs = integrators_page if name == "newton" else _section(
            integrators_page, "## Adaptive stepping")
        instance = cls()
        options = integrators.method_options("newmark")
        keys = {v: k for k, v in integrators.NEWTON_KEYS.items()} if name == "newton" else {}
        schema = {s["name"]: options[keys.get(s["name"], s["name"])][1] for s in settings}
    else:
        entry = next(m for m in METHODS if m["name"] == name)
        cls = integrators.METHODS[name]
        settings = entry["parameters"]
        docs = _section(integrators_page, f"## `{name}`: {cls.__name__}")
        instance = cls()
        schema = {k: d for k, (_, d) in integrators.method_options(name).items()}
        row = next(line for line in reference.splitlines() if line.startswith(f"| `{name}` |"))
        for key, default in schema.items():  # the reference of the model file shows them all
            assert f"`{key}` ({model_file._toml(default)})" in row, (name, key)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    signature = inspect.signature(cls).parameters
    for s in settings:
        core = s["default"]
        if core is None:  # required, an alternative or computed from the run: no value of its own
            assert fields[s["name"]].default in (dataclasses.MISSING, None), (name, s["name"])
            continue
        assert fields[s["name"]].default == core, (name, s["name"])
        assert signature[s["name"]].default == core
        assert f"{s['name']}={core!r}" in repr(instance)
        assert type(core) is _TYPES.get(s.get("kind"), float)  # a law's numbers: floats
        assert schema[s["name"]] == core and type(schema[s["name"]]) is type(core)
        if group == "settings" and name == "newton":
            assert f"{s['name']}={core!r}" in _docs_default(
                _section(integrators_page, "## `newmark`"), "newton")
        else:
            assert _docs_default(docs, s["name"]) == f"`{core!r}`", (name, s["name"])


def _valid_law_value(param: str) -> Any:
    curves = {"loading_penetration": [0.0, 1e-5], "loading_force": [0.0, 10.0],
              "unloading_penetration": [0.0, 1e-5], "unloading_force": [0.0, 5.0]}
    return curves.get(param, {"stiffness": 1e9, "restitution": 0.6, "damping": 40.0}.get(param))


def _one_alternative(parameters: list[dict[str, Any]]) -> dict[str, Any]:
    optional = [p["name"] for p in parameters if not p["required"] and p["default"] is None]
    return {optional[0]: _valid_law_value(optional[0])} if optional else {}


def test_the_integrators_are_the_catalogs_methods_in_its_order() -> None:
    assert list(integrators.METHODS) == NAMES
    for m in METHODS:
        cls = integrators.METHODS[m["name"]]
        assert cls.__name__ == m["class_name"] and cls().name == m["name"]
        assert getattr(vi.integrators, m["class_name"]) is cls
        assert [f.name for f in dataclasses.fields(cls) if f.init][2:] == [
            p["name"] for p in m["parameters"]]
        assert cls.supports_adaptive == (m["adaptive"] != "fixed")
        assert cls.impulsive == m["impulsive"] and cls.uses_newton == m["newton"]
        adaptive = cls().adaptive
        if m["adaptive"] == "by-default":
            assert adaptive == vi.Adaptive(**m["adaptive_defaults"])
        else:
            assert adaptive is None
    assert list(integrators.FORCE_METHODS) == [m["name"] for m in METHODS if not m["impulsive"]]


def _bad_values(group: str, setting: dict[str, Any]) -> list[Any]:
    """Values the core refuses for a setting: of the wrong type, and out of range."""
    wrong_type = {"number": [True, "0.5"], "integer": [2.5, True], "flag": [1, "yes"]}
    out_of_range = {"gamma": 1.0 if group == "bathe" else 0.4, "beta": 0.0, "rho_inf": 1.5,
                    "alpha": 0.5, "theta": 0.4, "chatter_fraction": 1.0,
                    "max_events_per_step": 0, "rtol": -1.0, "atol": -1.0, "max_iterations": 0,
                    "max_step_cuts": 41, "dt_min": 0.0,
                    "dt_max": -1.0}
    return wrong_type[setting["kind"]] + ([out_of_range[setting["name"]]]
                                          if setting["name"] in out_of_range else [])


def _targets() -> list[tuple[str, dict[str, Any]]]:
    out = [(m["name"], p) for m in METHODS for p in m["parameters"]]
    return out + [("newton", s) for s in integrators.CATALOG["newton"]] + [
        ("adaptive", s) for s in integrators.CATALOG["adaptive"]]


@pytest.mark.parametrize(("group", "setting"), _targets(),
                         ids=[f"{g}.{s['name']}" for g, s in _targets()])
def test_the_core_checks_every_setting_in_one_line(group: str, setting: dict[str, Any]) -> None:
    """A value the catalog refuses raises a one-line ModelError naming the field, the value (its
    repr) and what the catalog expects; the default is accepted."""
    build = {"newton": vi.NewtonOptions, "adaptive": vi.Adaptive}.get(
        group, integrators.METHODS.get(group))
    for bad in _bad_values(group, setting):
        with pytest.raises(ModelError) as err:
            build(**{setting["name"]: bad})
        message = str(err.value)
        assert message == (f"solver.{setting['name']}: {bad!r} is not valid; expected "
                           f"{setting['expected']}"), message
    build(**{setting["name"]: setting["default"]})


def test_cross_checks_are_the_cores() -> None:
    with pytest.raises(ModelError, match=r"^solver\.rtol: .*rtol > 0 or atol > 0$"):
        vi.Adaptive(rtol=0.0, atol=0.0)
    with pytest.raises(ModelError, match=r"^solver\.adaptive: true is not valid; expected false "
                                         r"for method 'bathe'; .* newmark, generalized-alpha, hht, "
                                         r"dop853$"):
        vi.Bathe(adaptive=vi.Adaptive())
    with pytest.raises(ModelError, match=r"^solver\.newton: .*dop853 is explicit"):
        vi.Dop853(newton=vi.NewtonOptions(rtol=1e-8))
    model = _impact_oscillator()
    with pytest.raises(ModelError, match=r"^solver\.dt_max: .* expected dt_max <= t_end"):
        vi.simulate(model, t_end=0.01, dt=1e-4, method=vi.Newmark(adaptive=vi.Adaptive(
            dt_max=0.1)))


@pytest.mark.filterwarnings("ignore::vibroimpact.ContactResolutionWarning")
@pytest.mark.parametrize("name", NAMES)
def test_the_cores_messages_name_each_method_by_its_one_name(name: str) -> None:
    """The core's refusal of a gap whose law the method does not take names the method as the
    catalog does (generalized-α and HHT were called "newmark" there)."""
    impulsive = integrators.METHODS[name].impulsive
    law = contact.KelvinVoigt(stiffness=1e7, damping=300.0) if impulsive else contact.Rigid(
        restitution=0.5)
    model = vi.Model(vi.Structure.sdof(1.0, 1e3, 0.0), gaps=[
        vi.Gap(dof=0, clearance=0.01, side="positive", law=law)], initial_velocity=[1.0])
    with pytest.raises(ModelError, match=r"^gaps\[0\]\.law\.kind: ") as err:
        vi.simulate(model, t_end=0.01, dt=1e-4, method=integrators.METHODS[name]())
    assert f"method '{name}'" in str(err.value), str(err.value)


def test_generalized_alpha_and_hht_are_newmark_family_schemes_of_the_core() -> None:
    """Their α-form as the core steps it: Chung & Hulbert's and HHT's formulas, written out
    here independently."""
    for rho in (0.0, 0.3, 0.57, 0.8, 1.0):
        am, af = (2 * rho - 1) / (rho + 1), rho / (rho + 1)
        assert vi.GeneralizedAlpha(rho_inf=rho).parameters() == {
            "alpha_m": am, "alpha_f": af, "gamma": 0.5 - am + af,
            "beta": 0.25 * (1 - am + af) ** 2}
    for a in (0.0, 0.05, 0.1, 1 / 3):
        assert vi.HHT(alpha=a).parameters() == {
            "alpha_m": 0.0, "alpha_f": a, "gamma": 0.5 + a, "beta": 0.25 * (1 + a) ** 2}
    # the spec's kind is the method's one name
    assert vi.GeneralizedAlpha().to_spec() == {"kind": "generalized-alpha", "rho_inf": 0.8}


def _impact_oscillator() -> vi.Model:
    """1 Hz, 5 % damping, a stiff Kelvin–Voigt stop (as tests/test_sweep.py's)."""
    k = (2 * np.pi) ** 2
    return vi.Model(vi.Structure.sdof(1.0, k, 0.1 * np.sqrt(k)),
                    gaps=[vi.Gap(dof=0, clearance=0.02, side="positive",
                                 law=contact.KelvinVoigt(stiffness=1e7, damping=300.0))],
                    loads=[vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=1.0)])


def test_the_api_model_files_and_sweeps_hand_the_core_one_typed_spec(tmp_path: Path) -> None:
    method = vi.Newmark(gamma=0.6, beta=0.3)
    spec = method._run_spec()["method"]
    assert isinstance(spec, _core.MethodSpec) and spec.kind == "newmark"
    assert method._run_spec()["method"] is spec  # built once per integrator
    sweep = Sweep(_impact_oscillator(), [Param("loads.0.frequency", [0.8, 1.2])], dt=1e-3,
                  method=method, transient=2, periods=2)
    assert _plan(sweep).job_spec(0)["method"] is spec
    path = tmp_path / "m.toml"
    path.write_text('schema_version = 1\n[structure]\nkind = "sdof"\nmass = 1.0\n'
                    'stiffness = 4e4\n[solver]\nmethod = "newmark"\ngamma = 0.6\nbeta = 0.3\n'
                    'dt = 1e-4\nt_end = 1e-2\n', encoding="utf-8")
    loaded = vi.io.load_model(path).method
    assert loaded == method and loaded._run_spec()["method"] == spec
    assert vi.Newmark(gamma=0.6, beta=0.31)._run_spec()["method"] != spec
    # pickled (a Dask worker's plan) without the core's object, rebuilt on use
    copy = pickle.loads(pickle.dumps(method))
    assert copy == method and copy._run_spec()["method"] == spec


def test_a_sweeps_adaptive_limits_default_in_the_core_to_its_period() -> None:
    """DOP853 in a sweep without dt_max takes the core's min(period/16, t_end): the same numbers
    as that written out, and other numbers than another dt_max (so that the check can fail)."""
    model = _impact_oscillator()
    freqs = (0.8, 1.3)

    def peaks(adaptive: vi.Adaptive) -> list[float]:
        sweep = Sweep(model, [Param("loads.0.frequency", freqs)], dt=0.1,
                      method=vi.Dop853(adaptive=adaptive), transient=3, periods=2)
        return run_sweep(sweep, threads=1)["displacement_max"].values.ravel().tolist()

    default = peaks(vi.Adaptive(rtol=1e-6, atol=1e-10))
    for i, f in enumerate(freqs):
        written = peaks(vi.Adaptive(rtol=1e-6, atol=1e-10, dt_max=min(1 / f / 16, 5 / f)))
        assert default[i] == written[i]
    other = peaks(vi.Adaptive(rtol=1e-6, atol=1e-10, dt_max=1 / freqs[0] / 64))
    assert default[0] != other[0]


def test_the_docs_and_reference_are_generated_from_the_catalog() -> None:
    page = (DOCS / "integrators.md").read_text(encoding="utf-8")
    assert page == generated_docs.integrators_page()
    assert re.search(r"^\| `dop853` \| .*`adaptive` \(true\), `rtol` \(1e-08\)",
                     model_file.render_reference(), re.M)


def _refused_model_fields() -> list[tuple[str, str, Any, Any]]:
    """(part, field, refused value, a build with it) for each checked field of the model."""
    hertz = contact.Hertz(stiffness=1e9)

    def radial(**kw: Any) -> Any:
        return lambda: vi.model.RadialGap(dof=[0, 1], law=hertz, **kw)

    return [
        ("gap", "clearance", -1e-3, lambda: vi.Gap(dof=0, law=hertz, clearance=-1e-3)),
        ("gap", "side", "left", lambda: vi.Gap(dof=0, law=hertz, side="left")),
        ("radial-gap", "clearance", -1.0, radial(clearance=-1.0)),
        ("radial-gap", "friction", -0.1, radial(friction=-0.1)),
        ("radial-gap", "radius", 0.0, radial(friction=0.1, radius=0.0)),
        ("radial-gap", "friction_law", "viscous", radial(friction_law="viscous")),
        ("radial-gap", "regularisation_speed", -2.0,
         radial(friction_law="regularised", regularisation_speed=-2.0)),
        ("radial-gap", "center", float("nan"), radial(center=[0.0, float("nan")])),
        ("load.harmonic", "frequency", -2.0,
         lambda: vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=-2.0)),
        ("load.harmonic", "phase", float("inf"),
         lambda: vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=2.0, phase=float("inf"))),
        ("load.constant", "amplitude", float("nan"),
         lambda: vi.ConstantLoad(dof=0, amplitude=float("nan"))),
        ("load.unbalance", "magnitude", -1.0, lambda: vi.UnbalanceLoad(dof=[0, 1], magnitude=-1.0)),
        ("load.table", "scale", float("inf"),
         lambda: vi.TableLoad(dof=0, time=[0.0, 1.0], force=[0.0, 1.0], scale=float("inf"))),
        ("structure", "spin_speed", float("nan"),
         lambda: vi.Structure([[1.0]], spin_speed=float("nan"))),
        ("structure", "spin_profile", "cubic", lambda: vi.Structure([[1.0]], spin_profile="cubic")),
        ("structure", "run_up_time", 0.0,
         lambda: vi.Structure([[1.0]]).run_up(spin_speed_end=1.0, run_up_time=0.0)),
    ]


@pytest.mark.parametrize(("part", "name", "value", "build"), _refused_model_fields(),
                         ids=lambda v: v if isinstance(v, str) else None)
def test_the_core_checks_the_models_fields_and_python_words_them(
        part: str, name: str, value: Any, build: Any) -> None:
    """The core refuses the value (``_core.model_field_accepts``, the check its own types run);
    the Python class refuses it in one line naming the field, the value and the core's
    ``expected``."""
    assert not _core.model_field_accepts(part, name, value)
    expected = vi.model.MODEL_CATALOG[part][name]["expected"]
    field = "structure" if part == "structure" else part.split("-")[-1].split(".")[0]
    with pytest.raises(ModelError, match=re.escape(f"{field}.{name}: {value!r} is not valid; "
                                                   f"expected {expected}")):
        build()


def test_a_spec_takes_the_cores_defaults_and_checks() -> None:
    """A model spec read by the core (``convert.rs``): a field left out takes the catalog's
    default (the run equals the one with the default written), a bad one is refused naming
    the gap or load and the catalog's ``expected``."""
    model = vi.Model(vi.Structure.sdof(1.0, 1e4), gaps=[vi.Gap(
        dof=0, clearance=1e-3, law=contact.Hertz(stiffness=1e9))], loads=[
        vi.HarmonicLoad(dof=0, amplitude=5.0, frequency=20.0)], initial_velocity=0.3)
    spec = model.to_spec()
    short = dict(spec, gaps=[{k: v for k, v in g.items() if k != "side"} for g in spec["gaps"]],
                 loads=[{k: v for k, v in ld.items() if k != "phase"} for ld in spec["loads"]])
    for key in ("spin_speed", "spin_profile", "spin_speed_end", "run_up_time"):
        short.pop(key)

    def run(model_spec: dict[str, Any]) -> Any:
        job = dict(model_spec, **vi.Newmark()._run_spec(), t_end=0.05, dt=1e-5, every=100,
                   record_dofs=[0])
        return _run_core(job, on_rows=None, chunk_rows=None, progress=None)[0]

    full, defaulted = run(spec), run(short)
    assert full["impacts"]["t_start"].size > 0  # the stop is hit: its side matters
    for key in ("time", "displacement", "velocity"):
        np.testing.assert_array_equal(defaulted[key], full[key])
    bad = dict(spec, gaps=[dict(spec["gaps"][0], clearance=-1.0)])
    with pytest.raises(ModelError, match=re.escape(
            "gaps[0].clearance: -1 is not valid; expected a clearance >= 0 in m")):
        _core.ModelSpec(bad).check()
    bad = dict(spec, loads=[dict(spec["loads"][0], frequency=-3.0)])
    with pytest.raises(ModelError, match=re.escape(
            "loads[0].frequency: -3 is not valid; expected a frequency >= 0 in Hz")):
        _core.ModelSpec(bad).check()
    with pytest.raises(ModelError, match=re.escape("structure.spin_profile: 'cubic' is not "
                                                   "valid; expected constant or linear")):
        _core.ModelSpec(dict(spec, spin_profile="cubic")).check()
