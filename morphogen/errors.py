"""Errors that carry a one-line message for the user.

Anything raised as a :class:`MorphogenError` is a problem with the user's input (a wrong name,
value, file or equation). The command line prints its message on one line and exits with
status 2; the Python API lets it propagate.
"""

from __future__ import annotations


class MorphogenError(ValueError):
    """A user-facing error: the message says what is wrong and how to fix it."""


class MorphogenWarning(UserWarning):
    """A problem that did not stop the run but makes its result less trustworthy; the
    command line prints it as one ``morphogen: warning:`` line."""


class BlowUpError(MorphogenError):
    """The simulation produced NaN, Inf or values beyond the overflow threshold.

    Attributes:
        step: the first step (1-based) after which the state was invalid.
        species: names of the species that were invalid at that step.
    """

    def __init__(self, step: int, species: tuple[str, ...], t: float):
        self.step = step
        self.species = species
        self.t = t
        names = ", ".join(species)
        super().__init__(
            f"numerical blow-up at step {step} (t={t:g}) in species {names}: "
            "reduce --dt, check the parameters, or use --clamp LO:HI to bound values explicitly"
        )


class UnstableTimeStepError(MorphogenError):
    """The explicit time step exceeds the diffusion stability limit."""

    def __init__(self, dt: float, dt_max: float, scheme: str):
        self.dt = dt
        self.dt_max = dt_max
        super().__init__(
            f"dt={dt:g} exceeds the {scheme} stability limit (diffusion and the linearised "
            "reaction, with a safety margin); "
            f"use --dt {dt_max:.6g} or smaller (or --unsafe to run anyway)"
        )


class DivergenceError(BlowUpError):
    """The run is diverging before it overflows: a growing grid-scale (checkerboard) mode or
    values far outside the range the run started from.

    Attributes:
        step, species, t: as for :class:`BlowUpError`.
        dt_suggested: a step to retry with.
        alternative: text after the suggested step, e.g. another scheme to try.
    """

    def __init__(self, step: int, species: tuple[str, ...], t: float, what: str,
                 dt_suggested: float, alternative: str = ""):
        self.step = step
        self.species = species
        self.t = t
        self.dt_suggested = dt_suggested
        names = ", ".join(species)
        ValueError.__init__(
            self,
            f"run diverging at step {step} (t={t:g}) in species {names}: {what}; "
            f"use --dt {dt_suggested:.6g} or smaller{alternative} (or --unsafe to run anyway)",
        )
