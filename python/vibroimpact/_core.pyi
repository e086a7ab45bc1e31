"""Type stubs of the compiled core (rust/vibroimpact-py)."""

from typing import Any

build_profile: str

class ModelError(ValueError): ...
class SolverError(RuntimeError): ...

def simulate(spec: dict[str, Any]) -> dict[str, Any]: ...
def hertz_stiffness(
    kind: str,
    radius1: float,
    radius2: float | None,
    youngs_modulus1: float,
    poisson1: float,
    youngs_modulus2: float,
    poisson2: float,
) -> float: ...
def contact_force(
    law: dict[str, Any], penetration: float, rate: float, impact_speed: float
) -> tuple[float, float, float]: ...
