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


def round_down(value: float, digits: int = 6) -> float:
    """``value`` cut (not rounded) to ``digits`` significant digits: the largest number of
    that many digits that is not above ``value``, so a step suggested in a message passes the
    check that suggested it (``0.005607578`` gives ``0.00560757``, where ``%.6g`` would print
    ``0.00560758``, above the limit). Zero, negative and non-finite values come back as they
    are."""
    import math
    from decimal import ROUND_FLOOR, Context, Decimal

    if not (math.isfinite(value) and value > 0):
        return value
    cut = float(Context(prec=digits, rounding=ROUND_FLOOR).plus(Decimal(value)))
    return cut if cut <= value else math.nextafter(cut, 0.0)


class UnstableTimeStepError(MorphogenError):
    """The explicit time step exceeds the diffusion stability limit.

    The suggested step in the message is the limit rounded *down* to 6 significant digits
    (:func:`round_down`), so running with it passes this check.
    """

    def __init__(self, dt: float, dt_max: float, scheme: str):
        self.dt = dt
        self.dt_max = dt_max
        super().__init__(
            f"dt={dt:g} exceeds the {scheme} stability limit (diffusion and the linearised "
            "reaction, with a safety margin); "
            f"use --dt {round_down(dt_max):.6g} or smaller (or --unsafe to run anyway)"
        )


class DivergenceError(BlowUpError):
    """The run is diverging before it overflows: a growing grid-scale (checkerboard) mode or
    values far outside the range the run started from.

    Attributes:
        step, species, t: as for :class:`BlowUpError`.
        dt_suggested: a step to retry with (the message shows it rounded down to 6 digits).
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
            f"use --dt {round_down(dt_suggested):.6g} or smaller{alternative} (or --unsafe to run "
            "anyway)",
        )
