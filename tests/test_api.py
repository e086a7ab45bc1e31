"""The Python API: model validation, result views, loads."""

from __future__ import annotations

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact.paper import cases


@pytest.fixture(scope="module")
def sdof_result() -> vi.Result:
    return vi.simulate(cases.sdof_model("lankarani-nikravesh"), t_end=0.005, dt=1e-6, every=5)


def test_dataframe_columns_carry_units(sdof_result: vi.Result) -> None:
    df = sdof_result.to_dataframe()
    assert df.index.name == "time [s]"
    for col in ("x0 [m]", "v0 [m/s]", "a0 [m/s^2]", "gap0 penetration [m]", "gap0 force [N]",
                "energy kinetic [J]"):
        assert col in df.columns
    assert np.array_equal(df["x0 [m]"].to_numpy(), sdof_result.displacement[:, 0])
    table = sdof_result.impacts.to_dataframe()
    assert list(table.columns)[:4] == ["gap", "side", "t_start", "t_end"]
    assert len(table) == len(sdof_result.impacts) == 3


def test_xarray_dataset_has_dims_units_and_settings(sdof_result: vi.Result) -> None:
    ds = sdof_result.to_xarray()
    assert ds["displacement"].dims == ("time", "dof")
    assert ds["contact_force"].dims == ("time", "gap")
    assert ds["displacement"].attrs["units"] == "m"
    assert ds["impact_force_max"].attrs["units"] == "N"
    assert ds.attrs["complete"] == 1
    assert ds.attrs["steps"] == 5000
    assert np.array_equal(ds["time"].values, sdof_result.time)


def test_summary_is_json_ready(sdof_result: vi.Result) -> None:
    import json

    s = json.loads(json.dumps(sdof_result.summary()))
    for key in ("max_abs_displacement", "impacts", "steps", "newton_iterations", "wall_time_s",
                "energy_balance_error"):
        assert key in s
    assert s["impacts"][0]["side"] == "positive"
    assert set(s["impacts"][0]) >= {"gap", "side", "t_start", "t_end", "v_in", "v_out",
                                    "restitution_effective", "delta_max", "force_max", "impulse"}
    # the last contact is still closed at 5 ms: its end is null, not NaN
    assert s["impacts"][-1]["t_end"] is None or s["impacts"][-1]["t_end"] > 0


def test_table_load_equals_the_same_constant_load() -> None:
    law = vi.contact.Hertz(stiffness=1e8)
    gap = vi.Gap(dof=0, clearance=1e-3, law=law)
    s = vi.Structure.sdof(mass=1.0, stiffness=1e3)
    const = vi.Model(s, gaps=[gap], loads=[vi.ConstantLoad(dof=0, amplitude=20.0)])
    table = vi.Model(s, gaps=[gap], loads=[vi.TableLoad(dof=0, time=[0, 1], force=[20.0, 20.0])])
    a = vi.simulate(const, t_end=0.2, dt=1e-5)
    b = vi.simulate(table, t_end=0.2, dt=1e-5)
    assert len(a.impacts) > 0
    assert np.array_equal(a.displacement, b.displacement)


def test_ramp_table_load_on_free_mass() -> None:
    """m x'' = F t / T: x = F t³ / (6 m T); Newmark's error is O(dt²)."""
    model = vi.Model(vi.Structure.sdof(mass=2.0),
                     loads=[vi.TableLoad(dof=0, time=[0.0, 1.0], force=[0.0, 10.0])])
    r = vi.simulate(model, t_end=1.0, dt=1e-3)
    exact = 10.0 * r.time**3 / (6 * 2.0)
    assert np.max(np.abs(r.displacement[:, 0] - exact)) < 1e-6 * exact[-1]


@pytest.mark.parametrize(
    ("build", "field"),
    [
        (lambda: vi.Structure([[1.0, 0.2], [0.0, 1.0]]), "structure.mass"),
        (lambda: vi.Structure([[1.0, 0.0], [0.0, -1.0]]), "structure.mass"),
        (lambda: vi.Structure.sdof(mass=0.0), "structure.mass"),
        (lambda: vi.Gap(dof=0, clearance=-1e-3, law=vi.contact.Hertz(stiffness=1e9)),
         "gap.clearance"),
        (lambda: vi.Gap(dof=0, side="left", law=vi.contact.Hertz(stiffness=1e9)), "gap.side"),
        (lambda: vi.Model(vi.Structure.sdof(mass=1.0),
                          gaps=[vi.Gap(dof=3, law=vi.contact.Hertz(stiffness=1e9))]),
         "gaps[0].dof"),
        (lambda: vi.Model(vi.Structure.sdof(mass=1.0), initial_velocity=[1.0, 2.0]),
         "initial.velocity"),
        (lambda: vi.simulate(vi.Model(vi.Structure.sdof(mass=1.0)), t_end=1.0, dt=0.0),
         "solver.dt"),
        (lambda: vi.simulate(vi.Model(vi.Structure.sdof(mass=1.0)), t_end=1.0, dt=2.0),
         "solver.dt"),
        (lambda: vi.simulate(vi.Model(vi.Structure.sdof(mass=1.0)), t_end=-1.0, dt=0.1),
         "solver.t_end"),
        (lambda: vi.simulate(vi.Model(vi.Structure.sdof(mass=1.0)), t_end=1.0, dt=0.1, every=0),
         "output.every"),
        (lambda: vi.simulate(vi.Model(vi.Structure.sdof(mass=1.0)), t_end=1.0, dt=0.1,
                             dofs=[2]), "output.dofs"),
        (lambda: vi.Newmark(gamma=0.4), "solver.gamma"),
        (lambda: vi.NewtonOptions(max_iterations=0), "solver.max_iterations"),
        (lambda: vi.HarmonicLoad(dof=0, amplitude=1.0, frequency=-2.0), "load.frequency"),
        (lambda: vi.TableLoad(dof=0, time=[0.0, 0.0], force=[1.0, 2.0]), "load.table.time"),
    ],
)
def test_bad_input_is_a_one_line_model_error(build, field: str) -> None:
    with pytest.raises(vi.ModelError) as err:
        build()
    msg = str(err.value)
    assert msg.startswith(field)
    assert "\n" not in msg


def test_dt_is_adjusted_to_a_whole_number_of_steps() -> None:
    r = vi.simulate(vi.Model(vi.Structure.sdof(mass=1.0, stiffness=1.0)), t_end=1.0, dt=0.3)
    assert r.stats.steps == 4 and r.dt == pytest.approx(0.25)
    assert r.time[-1] == pytest.approx(1.0)


def test_a_dense_model_compiled_at_its_first_run_gives_the_same_results() -> None:
    """``Model._core_spec``: a dense model's structure, gaps and loads are read into the core's
    ``ModelSpec`` once, compiled at its first run and reused by the next ones; those runs equal
    a run of a fresh model built the same way, and the model still copies and pickles (without
    the core's spec)."""
    import copy
    import pickle

    model = cases.sdof_model("hunt-crossley")
    first = vi.simulate(model, t_end=0.003, dt=1e-6)
    assert model._run_spec()["model"] is model._core_spec()
    again = vi.simulate(model, t_end=0.003, dt=1e-6)
    fresh = vi.simulate(cases.sdof_model("hunt-crossley"), t_end=0.003, dt=1e-6)
    for r in (again, fresh):
        assert np.array_equal(r.displacement, first.displacement)
        assert np.array_equal(r.impacts.t_start, first.impacts.t_start)
    for twin in (copy.deepcopy(model), pickle.loads(pickle.dumps(model))):
        assert twin == model and "_core_model" not in vars(twin)
        assert np.array_equal(vi.simulate(twin, t_end=0.003, dt=1e-6).displacement,
                              first.displacement)


def test_every_exception_of_the_core_is_the_packages_own() -> None:
    """One hierarchy: an ``except vi.SolverError`` (or ``vi.ModelError``) catches whatever any
    entry point of the compiled core raises, because the core raises the package's classes."""
    from vibroimpact import _core

    exported = {name: obj for name, obj in vars(_core).items()
                if isinstance(obj, type) and issubclass(obj, BaseException)}
    assert exported == {"ModelError": vi.ModelError}
    # a failure the core itself raises (the singular Newmark operator before the first step)
    model = vi.Model(structure=vi.Structure(mass=np.eye(1), stiffness=np.array([[-4e6]])))
    with pytest.raises(vi.SolverError, match="singular"):
        vi.simulate(model, t_end=0.01, dt=1e-3)


def test_a_result_from_the_core_equals_one_built_by_its_constructors(
        sdof_result: vi.Result) -> None:
    """``Result.from_core`` sets the fields of the result and of its impact table, energy
    account and statistics in one step each (``result._assembled``, not their ``__init__``):
    every one of them holds exactly its dataclass's fields, and equals the object those
    classes' constructors (with ``__post_init__``) build from the same values; without a model,
    the DOF units are ``__post_init__``'s default."""
    from dataclasses import fields, replace

    def rebuilt(obj):
        values = {f.name: getattr(obj, f.name) for f in fields(obj)}
        return type(obj)(**{k: rebuilt(v) if k in {"impacts", "energy", "stats"} else v
                            for k, v in values.items()})

    def same(a, b) -> None:
        assert type(a) is type(b) and set(vars(a)) == {f.name for f in fields(a)}
        for f in fields(a):
            x, y = getattr(a, f.name), getattr(b, f.name)
            if f.name in {"impacts", "energy", "stats"}:
                same(x, y)
            elif isinstance(x, np.ndarray):
                assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)
            else:
                assert x == y

    r = sdof_result
    assert len(r.impacts) > 0
    same(r, rebuilt(r))
    assert r.energy.balance_error > 0 and r.stats.steps == 5000
    assert r.dof_units == ("m",) and r.complete and r.message == "completed"
    # from_core without a model: the default units, as the constructor sets them
    from vibroimpact import _core

    model = cases.sdof_model("lankarani-nikravesh")
    spec = model._run_spec()
    spec.update(vi.Newmark()._run_spec(), t_end=0.001, dt=1e-6, every=1, record_dofs=[0])
    run = _core.start(spec, None, False)
    run.wait(1.0)
    bare = vi.Result.from_core(run.finish(), model=None, method=None, t_end=0.001)
    same(bare, replace(bare, dof_units=()))
    assert bare.dof_units == ("m",) and bare.dof_map is None


def test_integrators_share_the_default_newton_options() -> None:
    """An integrator given no Newton options holds the one default instance (checked once),
    equal to a fresh ``NewtonOptions()``; copies and pickles stay equal to the original and
    run the same."""
    import copy
    import pickle

    a, b = vi.Newmark(), vi.Dop853()
    assert a.newton is b.newton and a.newton == vi.NewtonOptions()
    assert vi.Newmark(newton=vi.NewtonOptions(max_iterations=7)).newton.max_iterations == 7
    model = cases.sdof_model("hertz")
    first = vi.simulate(model, t_end=0.002, dt=1e-6, method=a)
    for twin in (copy.deepcopy(a), pickle.loads(pickle.dumps(a))):
        assert twin == a
        assert np.array_equal(vi.simulate(model, t_end=0.002, dt=1e-6, method=twin).displacement,
                              first.displacement)
