"""Warnings for scene values that are valid but unlikely for soil and rock, each naming the unit the value
probably lacks; the scene still runs (docs/scenes.md, *`[materials.<name>]`*)."""

from __future__ import annotations

import math
import warnings

from warpsph.errors import SceneWarning
from warpsph.scene_sections import Material
from warpsph.scene_types import show

PLAUSIBLE_DENSITY = (500.0, 5000.0)
"""kg/m³: soils, rocks and their saturated mixtures lie between."""
PLAUSIBLE_MODULUS, PLAUSIBLE_COHESION = 1e5, 100.0
"""Pa: below these a value is likely in kPa (Young's modulus) or kPa (cohesion)."""
RADIAN_LIKE_ANGLE = math.pi / 2
"""Degrees: a friction or dilatancy angle above zero and at most this is likely in radians."""


def warn_implausible(material: Material, key: str) -> None:
    """One :class:`SceneWarning` per value unlikely for soil and rock, with the unit it probably
    lacks; the scene still runs."""
    lo, hi = PLAUSIBLE_DENSITY
    if not lo <= material.density <= hi:
        _warn(f"{key}.density = {show(material.density)} kg/m³ is outside {lo:g}–{hi:g} kg/m³ of soil and rock "
              "(kg/m³, not t/m³ or g/cm³)")  # fmt: skip
    if material.youngs_modulus < PLAUSIBLE_MODULUS:
        _warn(f"{key}.youngs_modulus = {show(material.youngs_modulus)} Pa is below {PLAUSIBLE_MODULUS:g} Pa, softer "
              "than any soil (Pa, not kPa or MPa)")  # fmt: skip
    if material.model == "viscoplastic" and 0.0 < material.cohesion < PLAUSIBLE_COHESION:
        _warn(f"{key}.cohesion = {show(material.cohesion)} Pa is below {PLAUSIBLE_COHESION:g} Pa (Pa, not kPa)")
    for name in ("friction_angle", "dilatancy_angle"):
        angle = getattr(material, name) if material.model == "viscoplastic" else 0.0
        if 0.0 < angle <= RADIAN_LIKE_ANGLE:
            _warn(f"{key}.{name} = {show(angle)}° is at most {RADIAN_LIKE_ANGLE:.3g}°, like an angle in radians "
                  f"({math.degrees(angle):.3g}° if it is one): angles are in degrees")  # fmt: skip


def _warn(message: str) -> None:
    warnings.warn(message, SceneWarning, stacklevel=2)
