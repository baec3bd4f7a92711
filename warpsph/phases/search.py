"""Strength reduction and the search for a safety phase's factor of safety (docs/scenes.md, *Phases*)."""

from __future__ import annotations

import dataclasses
import math

from warpsph.scene_sections import Material


def reduced_strength(material: Material, factor: float) -> Material:
    """``material`` with its strength divided by ``factor`` (strength reduction): c, the residual
    cohesion and the hardening modulus by F, tan φ and tan ψ by F (so ψ stays ≤ φ)."""
    def angle(degrees: float) -> float:
        return math.degrees(math.atan(math.tan(math.radians(degrees)) / factor))

    return dataclasses.replace(material, cohesion=material.cohesion / factor,
                               residual_cohesion=material.residual_cohesion / factor,
                               hardening_modulus=material.hardening_modulus / factor,
                               friction_angle=angle(material.friction_angle),
                               dilatancy_angle=angle(material.dilatancy_angle))  # fmt: skip


class FactorSearch:
    """The strength-reduction search of a safety phase, in rounds of ``width`` trials that may run at
    once: from F = 1 the factors grow (or shrink) by ``STEP`` until one trial stands and another fails,
    then the bracket between the largest factor that stood below the smallest that failed is cut into
    ``width`` + 1 equal parts until it is within ± ``tolerance``; the factor of safety is the bracket's
    middle. With ``width`` 1 the search is a bisection. Its state is plain data, kept in checkpoints."""

    STEP = 1.5
    SMALLEST = 0.05

    def __init__(self, tolerance: float, largest: float, state: dict | None = None, width: int = 1):
        self.tolerance, self.largest, self.width = tolerance, largest, max(1, width)
        self.state = state or {"stood": [], "failed": [], "factors": self._stepped(1.0, up=True, first=0)}

    @property
    def factors(self) -> list[float]:
        """The factors of the round's trials not yet recorded (empty: the search is over)."""
        return list(self.state["factors"])

    @property
    def factor(self) -> float | None:
        """The next trial's factor (None: the search is over)."""
        return self.state["factors"][0] if self.state["factors"] else None

    def record(self, factor: float, stands: bool) -> None:
        """Take the outcome of the trial at ``factor``, one of :attr:`factors`; the round recorded, choose
        the next."""
        s = self.state
        s["factors"].remove(factor)
        s["stood" if stands else "failed"].append(factor)
        if not s["factors"]:
            s["factors"] = self._next_round()

    @property
    def low(self) -> float | None:
        """The largest factor that stood below the smallest that failed."""
        high = self.high
        stood = [f for f in self.state["stood"] if high is None or f < high]
        return max(stood) if stood else None

    @property
    def high(self) -> float | None:
        """The smallest factor that failed."""
        return min(self.state["failed"]) if self.state["failed"] else None

    def _stepped(self, base: float, up: bool, first: int = 1) -> list[float]:
        """``width`` factors base·STEPᵏ (``up``) or base/STEPᵏ from k = ``first``, within [``SMALLEST``,
        ``largest``]."""
        return sorted({min(max(base * self.STEP**k if up else base / self.STEP**k, self.SMALLEST), self.largest)
                       for k in range(first, first + self.width)})  # fmt: skip

    def _next_round(self) -> list[float]:
        low, high = self.low, self.high
        if high is None:
            return [] if low >= self.largest else self._stepped(low, up=True)
        if low is None:
            return [] if high <= self.SMALLEST else self._stepped(high, up=False)
        if high - low <= 2.0 * self.tolerance:
            return []
        return [low + (high - low) * i / (self.width + 1) for i in range(1, self.width + 1)]

    @property
    def bracketed(self) -> bool:
        return self.low is not None and self.high is not None

    @property
    def result(self) -> float:
        """The factor of safety: the bracket's middle, or its one end if the search found no bracket."""
        low, high = self.low, self.high
        if self.bracketed:
            return 0.5 * (low + high)
        return low if low is not None else high
