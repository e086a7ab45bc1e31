"""Exudyn peer (``pip install exudyn``): the SDOF problems as an Exudyn user builds them.

* A ``Node1D`` with an ``ObjectMass1D``; one ``ObjectContactCoordinate`` per wall (its data
  node holds the gap and the impact speed), ``contactStiffnessExponent = n``,
  ``impactModel = 1`` with the restitution chosen so that its Hunt–Crossley factor
  ``1.5(1 − e)`` equals Lankarani–Nikravesh's ``3(1 − ce²)/4`` (PEERS.md; ``impactModel = 0``,
  no damping, for Hertz). The wall at ``x = −d``: markers (ground, mass), gap ``x + d``; the
  wall at ``x = +d``: markers (mass, ground), gap ``d − x`` (``offset = −d``).
* The structure's spring and damper: ``ObjectConnectorCoordinateSpringDamper``; the load: a
  ``LoadCoordinate`` with a Python ``loadUserFunction`` (called every Newton iteration).
* Implicit solver at a fixed step (``adaptiveStep = False``, full Newton: its modified Newton
  and recommended-step settings made the release step fail on the paper's case): Newmark
  (``useNewmark``, β = 1/4, γ = 1/2) or generalized-α (``spectralRadius`` 0.8). Exudyn has no
  event location: impact times are where ``|x|`` crosses the clearance, interpolated linearly
  between the stored steps; the peak is the largest step value.
* Timed as a user runs it: model build, ``SolveDynamic`` and the sensor data of every step.

The hollow shaft: :func:`run_beam` gives Exudyn our beam's matrices (``ObjectGenericODE2``),
so it integrates the same model; Exudyn's own beam elements (geometrically exact / ANCF)
would be a different discretisation.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from vibroimpact.benchmarks.peers.opensees_peer import crossings, sampled_contacts
from vibroimpact.benchmarks.peers.problems import SdofProblem

__all__ = ["available", "run_beam", "run_sdof", "version"]


def available() -> str | None:
    """None if Exudyn can be used, else the reason."""
    try:
        import exudyn  # noqa: F401
    except Exception as e:
        return f"exudyn not importable ({type(e).__name__}: {e}); pip install exudyn"
    return None


def version() -> str:
    try:
        import exudyn

        return str(exudyn.GetVersionString())
    except Exception:  # pragma: no cover
        return "unknown"


def run_sdof(p: SdofProblem, integrator: str = "newmark", dt: float | None = None
             ) -> dict[str, Any]:
    """One run (model build included); ``t``, ``x`` every step, ``peak``, ``impacts``."""
    import exudyn as exu
    from exudyn.itemInterface import (
        LoadCoordinate,
        MarkerNodeCoordinate,
        Node1D,
        NodeGenericData,
        NodePointGround,
        ObjectConnectorCoordinateSpringDamper,
        ObjectContactCoordinate,
        ObjectMass1D,
        SensorNode,
    )

    dt = p.dt if dt is None else dt
    n = round(p.t_end / dt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        sc = exu.SystemContainer()
        mbs = sc.AddSystem()
        node = mbs.AddNode(Node1D(referenceCoordinates=[0.0], initialCoordinates=[p.x0],
                                  initialVelocities=[p.v0]))
        mbs.AddObject(ObjectMass1D(nodeNumber=node, mass=p.mass))
        m_mass = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=0))
        m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()),
                                                      coordinate=0))
        if p.chi:
            law = {"impactModel": 1, "restitutionCoefficient": 1.0 - p.chi / 1.5}
            n_data = 2
        else:
            law = {"impactModel": 0}
            n_data = 1
        for s in p.sides:
            markers = [m_ground, m_mass] if s < 0 else [m_mass, m_ground]
            gap0 = p.clearance + s * -p.x0
            data = mbs.AddNode(NodeGenericData(numberOfDataCoordinates=n_data,
                                               initialCoordinates=[gap0] + [0.0] * (n_data - 1)))
            mbs.AddObject(ObjectContactCoordinate(
                markerNumbers=markers, nodeNumber=data, offset=-p.clearance,
                contactStiffness=p.contact_stiffness, contactStiffnessExponent=p.exponent, **law))
        if p.stiffness or p.damping:
            mbs.AddObject(ObjectConnectorCoordinateSpringDamper(
                markerNumbers=[m_ground, m_mass], stiffness=p.stiffness, damping=p.damping))
        if p.force_amplitude:
            amp, w = p.force_amplitude, 2 * math.pi * p.force_frequency

            def load(mbs: Any, t: float, load: float) -> float:
                return amp * math.sin(w * t)

            mbs.AddLoad(LoadCoordinate(markerNumber=m_mass, load=0.0, loadUserFunction=load))
        sensor = mbs.AddSensor(SensorNode(nodeNumber=node,
                                          outputVariableType=exu.OutputVariableType.Coordinates,
                                          storeInternal=True, writeToFile=False))
        _solve(exu, mbs, n, p.t_end, integrator)
        data = mbs.GetSensorStoredData(sensor)
    return sampled_contacts(np.asarray(data[:, 0]), np.asarray(data[:, 1]), p)


def _solve(exu: Any, mbs: Any, steps: int, t_end: float, integrator: str,
           dense: bool = False) -> None:
    """``SolveDynamic`` at a fixed step, full Newton, every step stored: Newmark (β = 1/4,
    γ = 1/2) or generalized-α (``spectralRadius`` 0.8); ``dense``: ``EigenDense`` solver."""
    if integrator not in ("newmark", "generalized-alpha"):
        raise ValueError(f"integrator: expected 'newmark' or 'generalized-alpha', got "
                         f"{integrator!r}")
    mbs.Assemble()
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = t_end
    ti.verboseMode = 0
    ti.adaptiveStep = False
    ti.newton.useModifiedNewton = False
    ti.newton.relativeTolerance = 1e-10
    ti.newton.absoluteTolerance = 1e-6
    ti.discontinuous.useRecommendedStepSize = False
    ti.generalizedAlpha.useNewmark = integrator == "newmark"
    ti.generalizedAlpha.newmarkBeta = 0.25
    ti.generalizedAlpha.newmarkGamma = 0.5
    ti.generalizedAlpha.spectralRadius = 0.8
    if dense:
        s.linearSolverType = exu.LinearSolverType.EigenDense
    s.solutionSettings.sensorsWritePeriod = t_end / steps
    s.solutionSettings.writeSolutionToFile = False
    mbs.SolveDynamic(s)


def run_beam(b: Any, integrator: str = "newmark") -> dict[str, Any]:
    """The hollow shaft as the same model in Exudyn: one ``NodeGenericODE2`` with our beam's
    42 coordinates and an ``ObjectGenericODE2`` with its mass and stiffness matrices (taken
    from :func:`vibroimpact.paper.cases.hollow_shaft_model`, so the discretisation is ours), the
    10 Hz load as one ``LoadCoordinate`` per node with a Python ``loadUserFunction`` (a
    ``forceUserFunction`` on the object is 3x slower: Exudyn differentiates it numerically for
    the Jacobian, 84 calls a step), and Hertz sliders as two ``ObjectContactCoordinate``
    (``impactModel = 0``, exponent 1.5) per slider coordinate. Fixed step, full Newton,
    ``EigenDense``; Newmark or generalized-α as for the SDOF problems (:func:`_solve`); every
    step stored by a sensor."""
    import exudyn as exu
    from exudyn.itemInterface import (
        LoadCoordinate,
        MarkerNodeCoordinate,
        NodeGenericData,
        NodeGenericODE2,
        NodePointGround,
        ObjectContactCoordinate,
        ObjectGenericODE2,
        SensorNode,
    )

    model = b.model()
    st = model.structure
    m, k, c = st.dense_matrices()
    n = m.shape[0]
    (load_,) = model.loads
    w = 2 * math.pi * load_.frequency
    steps = round(b.t_end / b.dt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        sc = exu.SystemContainer()
        mbs = sc.AddSystem()
        node = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * n,
                                           initialCoordinates=[0.0] * n,
                                           initialCoordinates_t=[0.0] * n,
                                           numberOfODE2Coordinates=n))
        extra = {"dampingMatrix": c} if np.any(c) else {}
        mbs.AddObject(ObjectGenericODE2(nodeNumbers=[node], massMatrix=m, stiffnessMatrix=k,
                                        **extra))

        def load(mbs: Any, t: float, load: float) -> float:
            return load * math.sin(w * t)

        for dof in load_.dofs:
            mbs.AddLoad(LoadCoordinate(
                markerNumber=mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=dof)),
                load=load_.amplitude, loadUserFunction=load))
        m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()),
                                                      coordinate=0))
        slider_dofs = []
        for g in model.gaps:
            dof, d = g.dofs[0], float(g.clearance)
            slider_dofs.append(dof)
            m_dof = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=dof))
            for markers in ([m_ground, m_dof], [m_dof, m_ground]):
                data = mbs.AddNode(NodeGenericData(numberOfDataCoordinates=1,
                                                   initialCoordinates=[d]))
                mbs.AddObject(ObjectContactCoordinate(
                    markerNumbers=markers, nodeNumber=data, offset=-d,
                    contactStiffness=g.law.contact_stiffness,
                    contactStiffnessExponent=float(g.law.exponent), impactModel=0))
        sensor = mbs.AddSensor(SensorNode(nodeNumber=node,
                                          outputVariableType=exu.OutputVariableType.Coordinates,
                                          storeInternal=True, writeToFile=False))
        _solve(exu, mbs, steps, b.t_end, integrator, dense=True)
        data = mbs.GetSensorStoredData(sensor)
    t = np.asarray(data[:, 0])
    impacts: list[list[Any]] = []
    for j, dof in enumerate(slider_dofs):
        clearance = float(model.gaps[j].clearance)
        impacts += crossings(t, np.asarray(data[:, 1 + dof]), clearance, (1, -1))
    mid = np.asarray(data[:, 1 + slider_dofs[1]])
    return {"t": t, "x": mid, "peak": float(np.abs(mid).max()),
            "impacts": sorted(impacts, key=lambda r: r[0])}
