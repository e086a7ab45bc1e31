"""OpenSeesPy peer (``pip install openseespy``): the SDOF problems as an OpenSees user builds
them (PEERS.md).

* ``ndm = 1, ndf = 1``; node 1 fixed, node 2 the mass; one ``zeroLength`` element per wall
  with ``uniaxialMaterial Hertzdamp Kh xiNorm gap n``. Hertzdamp pushes back when its strain
  is below ``−gap``, with the force ``Kh δⁿ (1 + xiNorm·δ̇/v_imp)``: Lankarani–Nikravesh with
  ``xiNorm = 3(1 − ce²)/4``, Hertz with ``xiNorm = 0``, the same physics as ours. The wall at
  ``x = −d`` is the element 1 → 2 (strain ``x``), the wall at ``x = +d`` the element 2 → 1
  (strain ``−x``).
* The structure's spring and damper: ``zeroLength`` elements with ``Elastic`` and ``Viscous``
  materials; the load: a ``Trig`` time series in a ``Plain`` pattern.
* ``Newmark`` (γ = 1/2, β = 1/4) or ``HHT`` (α = 0.9, i.e. our HHT α = 0.1), ``Newton``,
  ``NormDispIncr`` 1e-12, ``FullGeneral``, at the same fixed dt as ours (no event location:
  impact times are where ``|x|`` crosses the clearance, interpolated linearly between steps;
  the peak is the largest step value).
* Timed as a user runs it: model build included, ``analyze(1, dt)`` in a Python loop keeping
  ``nodeDisp`` every step.

The openseespy 3.7.1 Linux wheel bundles ``libblas.so.3`` but its ``opensees.so`` does not find
it on a machine without a system BLAS (``import openseespy`` then fails); :func:`load` preloads
the bundled library first, so that the PyPI wheel alone is enough.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.util
import os
from typing import Any

import numpy as np

from vibroimpact.benchmarks.peers.problems import SdofProblem

__all__ = ["available", "crossings", "load", "run_beam", "run_sdof", "sampled_contacts",
           "version"]

_OPS: Any = None
_ERROR: str | None = None


def load() -> Any:
    """The ``openseespy.opensees`` module, or raise ImportError with the reason."""
    global _OPS, _ERROR
    if _OPS is not None:
        return _OPS
    if _ERROR is not None:
        raise ImportError(_ERROR)
    try:
        spec = importlib.util.find_spec("openseespylinux")
        if spec is not None and spec.origin:
            blas = os.path.join(os.path.dirname(spec.origin), "lib", "libblas.so.3")
            if os.path.exists(blas):
                ctypes.CDLL(blas, mode=ctypes.RTLD_GLOBAL)
        import openseespy.opensees as ops
    except Exception as e:  # the wheel raises RuntimeError when its library fails to load
        _ERROR = f"openseespy not importable ({type(e).__name__}: {e}); pip install openseespy"
        raise ImportError(_ERROR) from e
    _OPS = ops
    return ops


def available() -> str | None:
    """None if OpenSeesPy can be used, else the reason."""
    try:
        load()
    except ImportError as e:
        return str(e)
    return None


def version() -> str:
    from importlib.metadata import version as v

    try:
        return v("openseespy")
    except Exception:  # pragma: no cover
        return "unknown"


def _build(ops: Any, p: SdofProblem, integrator: str) -> None:
    ops.wipe()
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    ops.node(1, 0.0)
    ops.node(2, 0.0)
    ops.fix(1, 1)
    ops.mass(2, p.mass)
    ops.uniaxialMaterial("Hertzdamp", 1, p.contact_stiffness, p.chi, p.clearance, p.exponent)
    tag = 1
    for s in p.sides:
        if s < 0:  # wall at x = -d: strain x
            ops.element("zeroLength", tag, 1, 2, "-mat", 1, "-dir", 1)
        else:  # wall at x = +d: strain -x
            ops.element("zeroLength", tag, 2, 1, "-mat", 1, "-dir", 1)
        tag += 1
    if p.stiffness:
        ops.uniaxialMaterial("Elastic", 2, p.stiffness)
        ops.element("zeroLength", tag, 1, 2, "-mat", 2, "-dir", 1)
        tag += 1
    if p.damping:
        ops.uniaxialMaterial("Viscous", 3, p.damping, 1.0)
        ops.element("zeroLength", tag, 1, 2, "-mat", 3, "-dir", 1)
        tag += 1
    if p.force_amplitude:
        ops.timeSeries("Trig", 1, 0.0, 1e10, 1.0 / p.force_frequency, "-factor",
                       p.force_amplitude)
        ops.pattern("Plain", 1, 1)
        ops.load(2, 1.0)
    if p.x0:
        ops.setNodeDisp(2, 1, p.x0, "-commit")
    if p.v0:
        ops.setNodeVel(2, 1, p.v0, "-commit")
    _transient(ops, integrator, numberer="Plain", system="FullGeneral")


def run_sdof(p: SdofProblem, integrator: str = "newmark", dt: float | None = None
             ) -> dict[str, Any]:
    """One run (model build included); ``t``, ``x`` every step, ``peak``, ``impacts``."""
    ops = load()
    dt = p.dt if dt is None else dt
    n = round(p.t_end / dt)
    dt = p.t_end / n
    with open(os.devnull, "w") as null, contextlib.redirect_stdout(null):
        _build(ops, p, integrator)
    x = np.empty(n + 1)
    x[0] = p.x0
    analyze, disp = ops.analyze, ops.nodeDisp
    for i in range(1, n + 1):
        if analyze(1, dt) != 0:
            raise RuntimeError(f"OpenSees analyze failed at t = {i * dt:g} s")
        x[i] = disp(2, 1)
    t = np.linspace(0.0, p.t_end, n + 1)
    return sampled_contacts(t, x, p)


def crossings(t: np.ndarray, x: np.ndarray, d: float, sides: tuple[int, ...]) -> list[list[Any]]:
    """Contacts ``[t_start, t_end]`` from a sampled history: where ``s·x`` crosses ``d`` up and
    down, interpolated linearly between the samples."""
    out: list[tuple[float, list[Any]]] = []
    for s in sides:
        u = s * np.asarray(x) - d
        closed = u > 0
        change = np.flatnonzero(closed[1:] != closed[:-1])
        start: float | None = None
        for i in change:
            tc = float(t[i] + (t[i + 1] - t[i]) * (-u[i]) / (u[i + 1] - u[i]))
            if closed[i + 1]:
                start = tc
            elif start is not None:
                out.append((start, [start, tc]))
                start = None
        if start is not None:
            out.append((start, [start, None]))
    return [r for _, r in sorted(out, key=lambda e: e[0])]


def sampled_contacts(t: np.ndarray, x: np.ndarray, p: SdofProblem) -> dict[str, Any]:
    """A fixed-step peer's SDOF history as the tables measure it: ``t``, ``x``, ``peak`` (the
    largest step value of |x|), ``impacts`` (:func:`crossings`) and ``contact_peaks`` (the
    largest step value of |x| inside each contact)."""
    impacts = crossings(t, x, p.clearance, p.sides)
    ax = np.abs(x)
    peaks = []
    for start, end in impacts:
        inside = (t >= start) & (t <= (t[-1] if end is None else end))
        peaks.append(float(ax[inside].max()) if inside.any() else p.clearance)
    return {"t": t, "x": x, "peak": float(ax.max()), "impacts": impacts,
            "contact_peaks": peaks}


def run_beam(b: Any, integrator: str = "newmark") -> dict[str, Any]:
    """The hollow shaft (:class:`~vibroimpact.benchmarks.peers.problems.BeamProblem`) in
    OpenSees, as the same model: ``ndm = 2, ndf = 3``, the beam along Y with its axial DOFs fixed,
    ``ElasticTimoshenkoBeam`` elements (E, G, A, I, κA from
    :func:`vibroimpact.paper.cases.hollow_shaft_beam`) with ``-cMass`` (consistent mass: its
    free–free frequencies equal ours to 9 digits, 477.712 / 1038.60 / 1647.25 Hz), Hertz sliders
    as two ``zeroLength`` ``Hertzdamp`` elements (ξ = 0) at the start, middle and end nodes,
    the load as a ``Trig`` series at every node; ``BandGeneral``, ``RCM``, Newton,
    ``NormDispIncr`` 1e-12; ``analyze(1, dt)`` in a loop keeping the three slider
    displacements every step. Returns the middle slider's ``peak`` and all ``impacts``."""
    from vibroimpact.paper import cases

    ops = load()
    beam = cases.hollow_shaft_beam("timoshenko", b.elements)
    model = b.model()
    sec, mat = beam.section, beam.material
    e_mod, nu, rho = mat.youngs_modulus, mat.poisson, mat.density
    g_mod = e_mod / (2 * (1 + nu))
    area, inertia = sec.area, sec.second_moment_x
    kappa = sec.shear_coefficient_for(nu)
    law = model.gaps[0].law
    clearance = float(model.gaps[0].clearance)
    n_el, length = b.elements, 1.0
    (load_,) = model.loads
    n = round(b.t_end / b.dt)
    dt = b.t_end / n
    sliders = (1, n_el // 2 + 1, n_el + 1)
    with open(os.devnull, "w") as null, contextlib.redirect_stdout(null):
        ops.wipe()
        ops.model("basic", "-ndm", 2, "-ndf", 3)
        for i in range(n_el + 1):
            ops.node(i + 1, 0.0, i * length / n_el)
            ops.fix(i + 1, 0, 1, 0)
        ops.geomTransf("Linear", 1)
        for e in range(n_el):
            ops.element("ElasticTimoshenkoBeam", e + 1, e + 1, e + 2, e_mod, g_mod, area,
                        inertia, kappa * area, 1, "-mass", rho * area, "-cMass")
        ops.uniaxialMaterial("Hertzdamp", 1, law.contact_stiffness, 0.0, clearance,
                             float(law.exponent))
        tag = 1000
        for nd in sliders:
            g = 1000 + nd
            ops.node(g, 0.0, (nd - 1) * length / n_el)
            ops.fix(g, 1, 1, 1)
            ops.element("zeroLength", tag, g, nd, "-mat", 1, "-dir", 1)  # wall at -d
            ops.element("zeroLength", tag + 1, nd, g, "-mat", 1, "-dir", 1)  # wall at +d
            tag += 2
        ops.timeSeries("Trig", 1, 0.0, 1e10, 1.0 / load_.frequency, "-factor",
                       load_.amplitude)
        ops.pattern("Plain", 1, 1)
        for i in range(n_el + 1):
            ops.load(i + 1, 1.0, 0.0, 0.0)
        _transient(ops, integrator, numberer="RCM", system="BandGeneral")
    x = np.zeros((n + 1, 3))
    analyze, disp = ops.analyze, ops.nodeDisp
    a, m_, c = sliders
    for i in range(1, n + 1):
        if analyze(1, dt) != 0:
            raise RuntimeError(f"OpenSees analyze failed at t = {i * dt:g} s")
        x[i] = (disp(a, 1), disp(m_, 1), disp(c, 1))
    t = np.linspace(0.0, b.t_end, n + 1)
    impacts: list[list[Any]] = []
    for j in range(3):
        impacts += crossings(t, x[:, j], clearance, (1, -1))
    return {"t": t, "x": x[:, 1], "peak": float(np.abs(x[:, 1]).max()),
            "impacts": sorted(impacts, key=lambda r: r[0])}


def _transient(ops: Any, integrator: str, numberer: str, system: str) -> None:
    """Newton iterations to 1e-12 on the displacement increment and the ``integrator``
    (``newmark``: average acceleration; ``hht``: HHT with OpenSees' α = 0.9, i.e. our 0.1)."""
    ops.constraints("Plain")
    ops.numberer(numberer)
    ops.system(system)
    ops.test("NormDispIncr", 1e-12, 50)
    ops.algorithm("Newton")
    if integrator == "newmark":
        ops.integrator("Newmark", 0.5, 0.25)
    elif integrator == "hht":
        ops.integrator("HHT", 0.9)
    else:
        raise ValueError(integrator)
    ops.analysis("Transient")
