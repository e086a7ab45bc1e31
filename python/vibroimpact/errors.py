"""Exceptions. A user's mistake is a :class:`ModelError` with a one-line message naming the
field, the value and what was expected; a run the solver could not finish is a
:class:`SolverError` that carries the results up to the failure."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vibroimpact._core import ModelError as ModelError

if TYPE_CHECKING:
    from pathlib import Path

    from vibroimpact.result import Result

__all__ = [
    "ContactResolutionWarning",
    "Interrupted",
    "ModelError",
    "PreRunWarning",
    "SolverError",
    "StepStabilityWarning",
]


class SolverError(RuntimeError):
    """The solver stopped before ``t_end``. ``partial`` holds the results up to then
    (``partial.complete`` is False)."""

    def __init__(self, message: str, partial: Result | None = None) -> None:
        super().__init__(message)
        self.partial = partial
        #: Files already holding the results up to the failure (streamed runs), if any.
        self.written: list[Path] = []


class Interrupted(SolverError):
    """The run was stopped by ``Ctrl-C`` (SIGINT) or SIGTERM. ``partial`` holds the results up
    to the instant it stopped (``partial.complete`` is False unless the run had just finished);
    ``signum`` is the signal received."""

    def __init__(self, message: str, partial: Result | None = None, signum: int = 2) -> None:
        super().__init__(message, partial)
        self.signum = signum


class PreRunWarning(UserWarning):
    """A setting that will spoil the run, found before it starts
    (:func:`vibroimpact.simulate.pre_run_warnings`); ``vibroimpact run`` prints each on one
    line."""


class ContactResolutionWarning(PreRunWarning):
    """The step is too long to resolve a contact: fewer than 10 steps per period of the
    contact oscillation estimated for a gap (:func:`vibroimpact.simulate.contact_periods`)."""


class StepStabilityWarning(PreRunWarning):
    """The step exceeds the critical step of a conditionally stable integrator (Newmark with
    ``2β < γ``) for the structure's highest natural frequency: the linear response grows
    without bound (:func:`vibroimpact.simulate.step_stability_messages`)."""


def require(condition: bool, field: str, value: object, expected: str) -> None:
    """Raise a one-line :class:`ModelError` unless ``condition`` holds."""
    if not condition:
        raise ModelError(f"{field}: {value!r} is not valid; expected {expected}")
