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
    middle. With ``width`` 1 the search is a bisection. An undecided trial counts neither way: it splits
    the bracket, the widest part is cut next, and the search ends once every part is within
    ± ``tolerance`` (:attr:`resolution` then says how wide the bracket stayed). Its state is plain
    data, kept in checkpoints."""

    STEP = 1.5
    SMALLEST = 0.05

    def __init__(self, tolerance: float, largest: float, state: dict | None = None, width: int = 1):
        self.tolerance, self.largest, self.width = tolerance, largest, max(1, width)
        self.state = state or {"stood": [], "failed": [], "factors": self._stepped(1.0, up=True, first=0)}
        self.state.setdefault("undecided", [])

    @property
    def factors(self) -> list[float]:
        """The factors of the round's trials not yet recorded (empty: the search is over)."""
        return list(self.state["factors"])

    @property
    def factor(self) -> float | None:
        """The next trial's factor (None: the search is over)."""
        return self.state["factors"][0] if self.state["factors"] else None

    def record(self, factor: float, stands: bool | None) -> None:
        """Take the outcome of the trial at ``factor``, one of :attr:`factors`: it stood (True), failed
        (False) or is undecided (None); the round recorded, choose the next."""
        s = self.state
        s["factors"].remove(factor)
        s["undecided" if stands is None else "stood" if stands else "failed"].append(factor)
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
        low, high, undecided = self.low, self.high, self.state["undecided"]
        if high is None:
            base = max(self.state["stood"] + undecided)
            return [] if base >= self.largest else self._stepped(base, up=True)
        if low is None:
            base = min(self.state["failed"] + undecided)
            return [] if base <= self.SMALLEST else self._stepped(base, up=False)
        ends = sorted({low, high, *(f for f in undecided if low < f < high)})
        a, b = max(zip(ends, ends[1:]), key=lambda part: part[1] - part[0])
        if b - a <= 2.0 * self.tolerance:
            return []
        return [a + (b - a) * i / (self.width + 1) for i in range(1, self.width + 1)]

    @property
    def bracketed(self) -> bool:
        return self.low is not None and self.high is not None

    @property
    def resolution(self) -> float:
        """Half the bracket's width: ``tolerance`` or less unless undecided trials kept it wider (nan
        without a bracket)."""
        return 0.5 * (self.high - self.low) if self.bracketed else math.nan

    @property
    def result(self) -> float:
        """The factor of safety: the bracket's middle, or its one end if the search found no bracket."""
        low, high = self.low, self.high
        if self.bracketed:
            return 0.5 * (low + high)
        return low if low is not None else high
