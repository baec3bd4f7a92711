"""Shared tools of the stability suite: the scoreboard's tools (:mod:`warpsph.stability.tools`) and
the suite's marks."""

from __future__ import annotations

from pathlib import Path

import pytest

from warpsph.stability.tools import (  # noqa: F401  (the suite's tools)
    DISC_DX, DISC_OMEGA, DISC_RADIUS, RIM_SPEED, SOLID, cell_share, closest_pair, energy, largest_rise, march,
    spinning_disc, step_jacobian,
)

SCHEMES = ("two_set", "collocated")
SCENES = Path(__file__).resolve().parents[2] / "scenes"
CONSISTENT = (("virtual_density", "real_motion"), ("velocity_filter", 0.02))
"""The virtual points' densities following the reals' motion, and the velocity filter (docs/method.md):
with both the disc keeps its energy without artificial viscosity, and its steady spin holds for 24 turns
(docs/stability.md)."""


def expected_failure(reason: str):
    """Mark of a case measured to fail: strict, so that a pass is reported as an error too."""
    return pytest.mark.xfail(strict=True, reason=reason)


def scheme_params(xfail: dict | None = None) -> list:
    """Both schemes as pytest parameters; those named in ``xfail`` are expected failures with the
    measured reason given."""
    xfail = xfail or {}
    return [pytest.param(s, marks=expected_failure(xfail[s])) if s in xfail else s for s in SCHEMES]
