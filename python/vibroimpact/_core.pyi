"""Type stubs of the compiled core (rust/vibroimpact-py)."""

from typing import Any

import numpy as np
from numpy.typing import NDArray

build_profile: str

class ModelError(ValueError): ...

class Running:
    inline: bool
    def wait(self, timeout: float) -> bool: ...
    def take_rows(self) -> dict[str, Any] | None: ...
    def take_events(self) -> tuple[list[dict[str, Any]], int]: ...
    def time(self) -> float: ...
    def finish(self) -> dict[str, Any]: ...

class CompiledSystem: ...

def compile_system(spec: dict[str, Any]) -> CompiledSystem: ...
def start(
    spec: dict[str, Any], chunk_rows: int | None = None, events: bool = False
) -> Running: ...
def request_interrupt() -> None: ...
def clear_interrupt() -> None: ...
def interrupt_requested() -> bool: ...
def expm(a: NDArray[np.float64]) -> NDArray[np.float64]: ...
def substitution_time(spec: dict[str, Any], solves: int) -> dict[str, Any]: ...
def precise_matrices(
    mass: NDArray[np.float64],
    damping: NDArray[np.float64],
    stiffness: NDArray[np.float64],
    dt: float,
) -> dict[str, Any]: ...
def newmark_floor_sdof(
    mass: float,
    stiffness: float,
    damping: float,
    clearance: float,
    contact_stiffness: float,
    exponent: float,
    hysteresis: float,
    v0: float,
    dt: float,
    steps: int,
) -> dict[str, NDArray[np.float64]]: ...
def contact_force(
    law: dict[str, Any],
    penetration: float,
    rate: float,
    impact_speed: float,
    max_penetration: float | None = None,
) -> tuple[float, float, float]: ...
def law_catalog() -> list[dict[str, Any]]: ...

class MethodSpec:
    kind: str
    def newmark_parameters(self) -> dict[str, float] | None: ...

def method_catalog() -> dict[str, Any]: ...
def method_spec(integrator: Any) -> MethodSpec: ...
def check_settings(group: str, settings: Any) -> None: ...
def contact_law_evaluate(
    law: dict[str, Any],
    penetration: NDArray[np.float64],
    rate: NDArray[np.float64],
    impact_speed: NDArray[np.float64],
    clamp: bool = False,
    max_penetration: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]: ...
def geometry_stiffness(
    kind: str,
    radius1: float,
    radius2: float | None,
    length: float | None,
    load: float | None,
    youngs_modulus1: float,
    poisson1: float,
    youngs_modulus2: float,
    poisson2: float,
) -> tuple[float, float]: ...
def flow_map(spec: dict[str, Any]) -> dict[str, Any]: ...
def sweep(
    specs: list[dict[str, Any]],
    chains: list[list[int]] | None = None,
    threads: int | None = None,
) -> dict[str, Any]: ...
def sweep_check(specs: list[dict[str, Any]], labels: list[str] | None = None) -> None: ...
