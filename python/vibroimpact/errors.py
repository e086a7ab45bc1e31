"""Exceptions. A user's mistake is a :class:`ModelError` with a one-line message naming the
field, the value and what was expected; a run the solver could not finish is a
:class:`SolverError` that carries the results up to the failure."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vibroimpact._core import ModelError as ModelError

if TYPE_CHECKING:
    from vibroimpact.result import Result

__all__ = ["ModelError", "SolverError"]


class SolverError(RuntimeError):
    """The solver stopped before ``t_end``. ``partial`` holds the results up to then
    (``partial.complete`` is False)."""

    def __init__(self, message: str, partial: Result | None = None) -> None:
        super().__init__(message)
        self.partial = partial


def require(condition: bool, field: str, value: object, expected: str) -> None:
    """Raise a one-line :class:`ModelError` unless ``condition`` holds."""
    if not condition:
        raise ModelError(f"{field}: {value!r} is not valid; expected {expected}")
