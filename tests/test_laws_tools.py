"""The contact-law library's parts (issue 5): analytic derivatives against finite differences
(property-based, through the core), parameter validation, stiffness from geometry, the
``vibroimpact laws`` command and the comparison plots."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib
import numpy as np
import pytest
import reference
import vibroimpact as vi
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from vibroimpact import contact
from vibroimpact.cli import main as cli_main
from vibroimpact.laws_compare import COMPARE_FIELDS, comparison_laws

matplotlib.use("Agg")

K = reference.paper_stiffness()
MASS, V0 = 0.04, 0.3
STEEL = {"youngs_modulus": 207e9, "poisson": 0.3}


def _tabulated() -> contact.Tabulated:
    x = np.linspace(0.0, 2e-5, 15)
    f = 2.0e9 * x**1.5
    return contact.Tabulated(x, f, x, f[-1] * (x / x[-1]) ** 4, reversal_band=0.05)


def _law(name: str) -> contact.ContactLaw:
    if name == "tabulated":
        return _tabulated()
    return comparison_laws(0.4, MASS, V0, 2.0e9, 1.3, [name])[name]


# --------------------------------------------------------------------------------------------
# Derivatives
# --------------------------------------------------------------------------------------------

_STATES = st.tuples(
    st.floats(-8.0, -4.0),  # log10 δ
    st.floats(-1.0, 1.0),  # δ̇, m/s
    st.floats(0.01, 3.0),  # v_imp, m/s
)


@pytest.mark.parametrize("name", list(contact.FORCE_LAWS))
def test_derivatives_equal_finite_differences(name: str) -> None:
    """∂F/∂δ and ∂F/∂δ̇ from the core equal central differences of its force at random
    (δ, δ̇, v_imp), the raw formula (unclamped), kinks of the tabulated law avoided."""
    law = _law(name)
    knots = np.asarray(law.loading_penetration) if name == "tabulated" else np.zeros(0)

    @settings(max_examples=40, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.filter_too_much])
    @given(_STATES)
    def check(state: tuple[float, float, float]) -> None:
        log_pen, rate, v_imp = state
        pen = 10.0**log_pen
        hp, hr = 1e-6 * pen, 1e-7 * v_imp
        if name == "tabulated":
            w = law.reversal_band * v_imp
            assume(np.all(np.abs(knots - pen) > 2 * hp))
            assume(abs(rate) > 2 * hr and abs(rate + w) > 2 * hr)
        f, dp, dr = (float(a[0]) for a in law.evaluate([pen], [rate], [v_imp]))
        fp = law.evaluate([pen + hp, pen - hp], [rate, rate], [v_imp, v_imp])[0]
        fr = law.evaluate([pen, pen], [rate + hr, rate - hr], [v_imp, v_imp])[0]
        fd_p = (fp[0] - fp[1]) / (2 * hp)
        fd_r = (fr[0] - fr[1]) / (2 * hr)
        assert dp == pytest.approx(fd_p, abs=1e-6 * (abs(dp) + abs(f) / pen)), state
        assert dr == pytest.approx(fd_r, abs=1e-6 * (abs(dr) + abs(f) / v_imp)), state

    check()


def test_clamped_force_is_compressive_with_zero_tangent() -> None:
    for name in contact.FORCE_LAWS:
        f, dp, dr = _law(name).evaluate([1e-6, 1e-6], [-50.0, 0.1], [0.3, 0.3], clamp=True)
        assert np.all(f >= 0.0), name
        assert np.all((f > 0) | ((dp == 0) & (dr == 0))), name


# --------------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", contact.RESTITUTION_LAWS)
@pytest.mark.parametrize("ce", [0.0, -0.1, 1.2, float("nan"), None])
def test_restitution_is_validated(name: str, ce: float | None) -> None:
    with pytest.raises(vi.ModelError, match=r"^law\.restitution: ") as err:
        contact.LAWS[name](stiffness=1e9, restitution=ce)  # type: ignore[call-arg]
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"loading_penetration": [0.0, 1e-5], "loading_force": [0.0]}, "law.loading_force"),
        ({"loading_penetration": [1e-6, 1e-5]}, "law.loading"),
        ({"loading_penetration": [0.0, 2e-5, 1e-5]}, "law.loading_penetration"),
        ({"loading_force": [0.0, 20.0, 10.0]}, "law.loading_force"),
        ({"unloading_force": [0.0, 11.0, 30.0]}, "unloading curve is above"),
        ({"unloading_force": [0.0, 0.0, 0.0]}, "unloading_force ends at 0 N"),
        ({"reversal_band": 0.0}, "law.reversal_band"),
        ({"loading_force": [0.0, 10.0, 10.0]}, "law.loading_force"),
    ],
)
def test_tabulated_is_validated(kwargs: dict, field: str) -> None:
    base = {
        "loading_penetration": [0.0, 1e-5, 2e-5],
        "loading_force": [0.0, 10.0, 30.0],
        "unloading_penetration": [0.0, 1e-5, 2e-5],
        "unloading_force": [0.0, 5.0, 15.0],
    }
    with pytest.raises(vi.ModelError, match=field.replace(".", r"\.")) as err:
        contact.Tabulated(**{**base, **kwargs})
    assert "\n" not in str(err.value)


def test_law_from_name_refuses_foreign_parameters() -> None:
    with pytest.raises(vi.ModelError, match=r"law\.stiffness: not a parameter of tabulated"):
        contact.law_from_name("tabulated", stiffness=1e9)
    with pytest.raises(vi.ModelError, match=r"law\.loading_force: missing"):
        contact.law_from_name("tabulated", loading_penetration=[0.0, 1.0])


def test_tabulated_follows_its_curves() -> None:
    t = contact.Tabulated.from_curves([(0, 0), (1e-5, 10), (2e-5, 30)],
                                      [(0, 0), (1e-5, 5), (2e-5, 30)])
    assert t.force(1.5e-5, 0.2, 0.3)[0] == pytest.approx(20.0)
    assert t.force(1.5e-5, -0.2, 0.3)[0] == pytest.approx(17.5)  # the unloading curve
    assert t.force(3e-5, -0.2, 0.3)[0] == pytest.approx(50.0)  # loading, continued linearly
    # Turned at 1e-5 (10 N): the unloading curve stretched by 1/2 in δ, by 10/30 in F.
    assert t.force(0.5e-5, -0.2, 0.3, max_penetration=1e-5)[0] == pytest.approx(5.0 / 3.0)
    assert t.contact_stiffness == pytest.approx(1.5e6)


# --------------------------------------------------------------------------------------------
# Stiffness from geometry
# --------------------------------------------------------------------------------------------


def test_flat_punch_stiffness() -> None:
    g = contact.Geometry("flat-punch", radius1=0.002, **STEEL)
    e_star = 207e9 / (2 * (1 - 0.3**2))
    assert g.stiffness() == pytest.approx(2 * 0.002 * e_star, rel=1e-12)
    assert g.exponent == 1.0


def test_cylinder_in_hole_is_the_secant_of_johnson() -> None:
    r1, r2, length, load = 0.0095, 0.0100, 0.02, 2000.0
    g = contact.Geometry("cylinder-in-hole", radius1=r1, radius2=r2, length=length, load=load,
                         youngs_modulus=207e9, poisson=0.3, youngs_modulus2=70e9, poisson2=0.33)
    e_star = 1 / ((1 - 0.3**2) / 207e9 + (1 - 0.33**2) / 70e9)
    c = math.pi * length * e_star
    delta = load / c * (math.log(4 * c * (r2 - r1) / load) - 1)
    assert g.stiffness() == pytest.approx(load / delta, rel=1e-12)
    law = contact.Flores(stiffness=g, exponent=1.0, restitution=0.8)
    assert law.contact_stiffness == pytest.approx(load / delta, rel=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"kind": "cylinder-in-hole", "radius1": 0.01, "radius2": 0.009, "length": 0.02,
          "load": 100.0}, "radius2"),
        ({"kind": "cylinder-in-hole", "radius1": 0.01, "radius2": 0.0101, "length": 0.02,
          "load": 1e12}, "load"),
        ({"kind": "cylinder-in-hole", "radius1": 0.01, "radius2": 0.0101}, "geometry.length"),
        ({"kind": "flat-punch", "radius1": -1.0}, "radius"),
    ],
)
def test_bad_geometry_is_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(vi.ModelError, match=match) as err:
        contact.Geometry(**kwargs, **STEEL)
    assert "\n" not in str(err.value)


def test_law_exponent_must_match_geometry() -> None:
    punch = contact.Geometry("flat-punch", radius1=0.002, **STEEL)
    with pytest.raises(vi.ModelError, match=r"law\.exponent: 1\.5 is not valid"):
        contact.HuGuo(stiffness=punch, restitution=0.5)


def test_model_file_takes_new_laws_and_geometries(tmp_path: Path) -> None:
    (tmp_path / "m.toml").write_text("""
[structure]
kind = "sdof"
mass = 0.04

[[gaps]]
dof = 0
[gaps.law]
kind = "tabulated"
loading_penetration = [0.0, 1e-5, 2e-5, 4e-5]
loading_force = [0.0, 100.0, 300.0, 800.0]
unloading_penetration = [0.0, 2e-5, 4e-5]
unloading_force = [0.0, 0.0, 800.0]

[[gaps]]
dof = 0
clearance = 0.001
side = "negative"
[gaps.law]
kind = "carvalho-martins"
exponent = 1
restitution = 0.5
[gaps.law.geometry]
kind = "cylinder-in-hole"
radius1 = 0.0095
radius2 = 0.01
length = 0.02
load = 2000
youngs_modulus = 207e9
poisson = 0.3

[initial]
velocity = 0.3

[solver]
dt = 1e-7
t_end = 1e-3
""", encoding="utf-8")
    mf = vi.load_model(tmp_path / "m.toml")
    assert isinstance(mf.model.gaps[0].law, contact.Tabulated)
    assert isinstance(mf.model.gaps[1].law, contact.CarvalhoMartins)
    result = mf.simulate()
    # ½ m v² = 1.8 mJ is stored at δ_m on the loading segment 100 N + 2e7 N/m (δ − 1e-5);
    # the unloading line stretched to (δ_m/2, 0)–(δ_m, F_L(δ_m)) returns F_L(δ_m) δ_m / 4.
    energy = 0.5 * 0.04 * 0.3**2
    u = (-100.0 + math.sqrt(100.0**2 + 4e7 * (energy - 0.5e-3))) / 2e7
    dm, f_m = 1e-5 + u, 100.0 + 2e7 * u
    assert result.impacts.delta_max[0] == pytest.approx(dm, rel=1e-5)
    e = math.sqrt(f_m * dm / 4.0 / energy)
    assert result.impacts.restitution_effective[0] == pytest.approx(e, abs=1e-4)


# --------------------------------------------------------------------------------------------
# vibroimpact laws, plots
# --------------------------------------------------------------------------------------------


def test_cli_laws_json(capsys: pytest.CaptureFixture[str]) -> None:
    code = cli_main(["laws", "--restitution", "0.5", "--velocity", "0.3", "--mass", "0.04",
                     "--geometry", "ball-in-socket", "--radius1", "0.01", "--radius2", "0.0099",
                     "--youngs-modulus", "207e9", "--poisson", "0.3", "--json"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out) == list(contact.FORCE_LAWS)
    for row in out.values():
        assert tuple(row) == COMPARE_FIELDS
    assert out["hertz"]["restitution_effective"] == pytest.approx(1.0, abs=1e-10)
    assert out["exact-restitution"]["restitution_effective"] == pytest.approx(0.5, abs=1e-9)
    # the same numbers as `vibroimpact impact --json` for that law
    code = cli_main(["impact", "--law", "flores", "--stiffness", str(K), "--restitution", "0.5",
                     "--mass", "0.04", "--velocity", "0.3", "--json"])
    single = json.loads(capsys.readouterr().out)
    for key in COMPARE_FIELDS:
        assert out["flores"][key] == pytest.approx(single[key], rel=1e-9)


def test_cli_laws_text_and_errors(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    fig = tmp_path / "laws.png"
    code = cli_main(["laws", "--restitution", "0.7", "--velocity", "0.3", "--mass", "0.04",
                     "--stiffness", "1e9", "--laws", "hertz", "hu-guo", "tabulated",
                     "--plot", str(fig)])
    out = capsys.readouterr().out
    assert code == 0 and "hu-guo" in out and "delta_max [m]" in out
    assert fig.stat().st_size > 0
    code = cli_main(["laws", "--restitution", "0.7", "--velocity", "0.3", "--mass", "0.04",
                     "--geometry", "flat-punch", "--radius1", "0.001", "--youngs-modulus", "2e11"])
    assert code == 2
    assert "--poisson: missing" in capsys.readouterr().err


def test_plot_laws_has_labelled_axes(tmp_path: Path) -> None:
    from vibroimpact.plotting.laws import plot_laws

    laws = comparison_laws(0.5, MASS, V0, K, 1.5, ["hertz", "flores", "kelvin-voigt"])
    fig = plot_laws(laws, MASS, V0, path=tmp_path / "loops.svg")
    left, right = fig.axes[:2]
    assert left.get_xlabel() == "penetration δ [m]"
    assert left.get_ylabel() == "contact force F [N]"
    assert right.get_ylabel() == "penetration rate dδ/dt [m/s]"
    assert len(left.get_lines()) == 3
    # the Hertz curve returns at -v0, Flores' at about -0.47 v0
    rates = {line.get_label(): line.get_ydata() for line in right.get_lines()}
    assert rates["hertz"][0] == pytest.approx(V0, rel=1e-3)
    assert min(rates["hertz"]) == pytest.approx(-V0, rel=1e-3)
    assert min(rates["flores"]) == pytest.approx(-0.4704 * V0, rel=2e-3)
    assert (tmp_path / "loops.svg").stat().st_size > 0


REMOVED = ("law 'safaeifar-karimi' was removed: it was a stand-in, not the published law; "
           "use 'exact-restitution' (the same relation under its own name)")


def test_removed_law_name_is_refused_with_its_reason(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """``safaeifar-karimi`` (a stand-in under a paper's name) is refused everywhere a law is
    named, in one line that points to ``exact-restitution``; nothing is written."""
    assert "safaeifar-karimi" not in contact.LAWS
    with pytest.raises(vi.ModelError) as info:
        contact.law_from_name("safaeifar-karimi", stiffness=K, restitution=0.5)
    assert str(info.value) == REMOVED
    with pytest.raises(vi.ModelError) as info:
        comparison_laws(0.5, MASS, V0, K, 1.5, ["flores", "safaeifar-karimi"])
    assert str(info.value) == REMOVED
    model = tmp_path / "m.toml"
    model.write_text('[structure]\nkind = "sdof"\nmass = 1.0\n\n[[gaps]]\ndof = 0\n'
                     'clearance = 0.001\n\n[gaps.law]\nkind = "safaeifar-karimi"\n'
                     'stiffness = 1e9\nrestitution = 0.5\n\n[initial]\nvelocity = 1.0\n\n'
                     '[solver]\ndt = 1e-5\nt_end = 0.01\n', encoding="utf-8")
    with pytest.raises(vi.ModelError) as info:
        vi.load_model(model)
    assert str(info.value) == f"gaps[0].law.kind: {REMOVED}"
    capsys.readouterr()
    for argv in (
        ["impact", "--law", "safaeifar-karimi", "--stiffness", "1e9", "--restitution", "0.5",
         "--mass", "0.04", "--velocity", "0.3"],
        ["laws", "--restitution", "0.5", "--velocity", "0.3", "--mass", "0.04",
         "--stiffness", "1e9", "--laws", "hertz", "safaeifar-karimi"],
        ["run", str(model), "-o", str(tmp_path / "out.csv")],
    ):
        assert cli_main(argv) == 2, argv
        captured = capsys.readouterr()
        assert captured.out == "", argv
        assert captured.err.splitlines() == [
            "vibroimpact: error: " + ("gaps[0].law.kind: " if argv[0] == "run" else "") + REMOVED
        ], argv
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.toml"]
    # the help lists only the laws there are
    with pytest.raises(SystemExit):
        cli_main(["impact", "--help"])
    assert "safaeifar" not in capsys.readouterr().out


@pytest.mark.parametrize("ce", [0.05, 0.135, 0.3, 0.5, 0.9, 0.999])
def test_kelvin_voigt_damping_restitutes_ce(ce: float) -> None:
    """The dashpot of :func:`contact.kelvin_voigt_damping` (overdamped below ce = e⁻²) makes one
    clamped Kelvin–Voigt impact restitute ce: to 1e-8 in the independent SciPy integration
    (the clamp located by its event) and in the core's DOP853, which locate the clamp; the
    textbook ζ = −ln ce/√(π² + ln² ce) would miss by up to 0.15."""
    k, mass, v0 = 2.0e7, 0.3, 1.2
    c = contact.kelvin_voigt_damping(ce, k, mass)
    ref = reference.single_impact("kelvin-voigt", mass, v0, rtol=1e-10, stiffness=k,
                                  exponent=1.0, damping=c)
    assert ref["restitution_effective"] == pytest.approx(ce, abs=1e-8)
    model = vi.Model(structure=vi.Structure.sdof(mass=mass), initial_velocity=v0,
                     gaps=[vi.Gap(dof=0, clearance=0.0, side="positive",
                                  law=contact.KelvinVoigt(stiffness=k, damping=c))])
    run = vi.simulate(model, t_end=20 * math.sqrt(mass / k) * (1 + c / math.sqrt(k * mass)),
                      dt=1e-5, method=vi.integrators.Dop853())
    assert run.impacts.restitution_effective[0] == pytest.approx(ce, abs=1e-8)


def test_cli_impact_kelvin_voigt_with_restitution_is_the_laws_entry(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``impact --law kelvin-voigt --restitution CE --mass M`` and ``laws --restitution CE`` build
    the same Kelvin–Voigt contact (with exponent 1 ``laws`` gives it the stiffness K itself), so
    every number agrees, and it restitutes CE to 1e-8 (the relation is exact for the clamped
    contact, whose clamp DOP853 locates); giving a damping as well is refused."""
    ce, k, mass, v0 = 0.2, 3.0e7, 0.04, 0.3
    common = ["--restitution", str(ce), "--mass", str(mass), "--velocity", str(v0),
              "--stiffness", str(k)]
    assert cli_main(["impact", "--law", "kelvin-voigt", *common, "--json"]) == 0
    single = json.loads(capsys.readouterr().out)
    assert cli_main(["laws", *common, "--exponent", "1", "--laws", "kelvin-voigt",
                     "--json"]) == 0
    side_by_side = json.loads(capsys.readouterr().out)["kelvin-voigt"]
    for key in ("v_out", "delta_max", "force_max", "duration", "restitution_effective"):
        assert single[key] == pytest.approx(side_by_side[key], rel=1e-12), key
    assert single["restitution_effective"] == pytest.approx(ce, abs=1e-8)
    assert cli_main(["impact", "--law", "kelvin-voigt", *common, "--damping", "5"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == ["vibroimpact: error: law: kelvin-voigt takes one of --restitution or "
                   "--damping; got restitution=0.2, damping=5.0"]
