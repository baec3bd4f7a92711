"""Validation of a scene's materials: the elastic, viscoplastic and retention constants, their units and
ranges (docs/scenes.md, *Materials*); :mod:`warpsph.scene_check` calls it for the whole scene."""

from __future__ import annotations

from warpsph.errors import SceneError
from warpsph.physics.retention import RETENTION
from warpsph.scene_plausible import warn_implausible
from warpsph.scene_sections import Effects, Material
from warpsph.scene_types import (FRICTION_ANGLES, NON_NEGATIVE, POSITIVE, UNIT_INTERVAL, WATER_DENSITIES, Interval,
                                 check_choice, check_instance, check_name, check_range, check_types, show)  # fmt: skip

YIELD_FUNCTIONS = ("von_mises", "drucker_prager", "mohr_coulomb")
MIN_MODULUS = 1.0e3
"""Moduli below this [Pa] are taken for a unit mistake (kPa or MPa written as Pa)."""


def check_materials(materials: dict, effects: Effects) -> None:
    if not isinstance(materials, dict):
        raise SceneError("materials", f"expected a table of materials, got {type(materials).__name__}")
    if not materials:
        raise SceneError("materials", "at least one material is required, e.g. [materials.soil]")
    for name, material in materials.items():
        check_name(f"materials[{show(name)}]", name)
        key = f"materials.{name}"
        check_instance(key, material, Material)
        check_types(material, key)
        check_choice(f"{key}.model", material.model, ("elastic", "viscoplastic"))
        if material.model == "viscoplastic":
            _check_viscoplastic(material, key, effects)
        check_range(f"{key}.porosity", material.porosity, UNIT_INTERVAL)
        if material.water_density not in WATER_DENSITIES:
            raise SceneError(
                f"{key}.water_density",
                f"must be {WATER_DENSITIES} kg/m³ (water is about 1000 kg/m³; not g/cm³ or t/m³), "
                f"got {show(material.water_density)}",
            )
        check_range(f"{key}.density", material.density, POSITIVE)
        if material.grain_density is not None:
            check_range(f"{key}.grain_density", material.grain_density, POSITIVE)
            mixture = mixture_density(material)
            if abs(material.density - mixture) > 1e-9 * mixture:
                raise SceneError(
                    f"{key}.density",
                    "with grain_density given, must be the mixture density "
                    f"(1 - porosity) grain_density + porosity water_density = {show(mixture)}, "
                    f"got {show(material.density)}",
                )
        check_modulus(f"{key}.youngs_modulus", material.youngs_modulus)
        check_range(f"{key}.poisson_ratio", material.poisson_ratio, Interval(-1.0, 0.5))
        check_modulus(f"{key}.grain_bulk_modulus", material.grain_bulk_modulus)
        check_modulus(f"{key}.water_bulk_modulus", material.water_bulk_modulus)
        conductivity = material.hydraulic_conductivity
        check_range(f"{key}.hydraulic_conductivity", conductivity, NON_NEGATIVE)
        if conductivity > 1.0:
            raise SceneError(
                f"{key}.hydraulic_conductivity",
                "must be <= 1 m/s: k_h is in m/s (not cm/s, nor a permeability in m²) "
                f"and no soil is more permeable, got {show(conductivity)}",
            )
        if material.k0 is not None:
            check_range(f"{key}.k0", material.k0, NON_NEGATIVE)
        _check_retention(material, key, effects)
        warn_implausible(material, key)
    _check_one_yield_function(materials)


def _check_viscoplastic(material: Material, key: str, effects: Effects) -> None:
    if not effects.plasticity:
        raise SceneError(f"{key}.model", '"viscoplastic" needs effects.plasticity = true')
    check_choice(f"{key}.yield_function", material.yield_function, YIELD_FUNCTIONS)
    check_range(f"{key}.cohesion", material.cohesion, NON_NEGATIVE)
    check_range(f"{key}.friction_angle", material.friction_angle, FRICTION_ANGLES)
    if material.yield_function == "von_mises" or material.friction_angle == 0.0:
        check_range(f"{key}.cohesion", material.cohesion, POSITIVE)
    check_range(f"{key}.dilatancy_angle", material.dilatancy_angle,
                Interval(0.0, material.friction_angle, True, True))  # fmt: skip
    check_range(f"{key}.residual_cohesion", material.residual_cohesion, Interval(0.0, material.cohesion, True, True))
    check_range(f"{key}.fluidity", material.fluidity, POSITIVE)
    check_range(f"{key}.reference_stress", material.reference_stress, POSITIVE)
    check_range(f"{key}.rate_exponent", material.rate_exponent, Interval(1.0, lo_closed=True, hi_closed=True))


def _check_retention(material: Material, key: str, effects: Effects) -> None:
    check_choice(f"{key}.retention", material.retention, tuple(RETENTION))
    if material.retention == "saturated":
        return
    needs_pore_water(f"{key}.retention", effects, "a retention curve ")
    check_range(f"{key}.retention_alpha", material.retention_alpha, POSITIVE)
    if material.retention == "van_genuchten":
        check_range(f"{key}.retention_n", material.retention_n, Interval(1.0))
    check_range(f"{key}.residual_saturation", material.residual_saturation, Interval(0.0, 1.0, lo_closed=True))


def _check_one_yield_function(materials: dict) -> None:
    """The kernels compile one yield function per scene."""
    first = None
    for name, material in materials.items():
        if material.model != "viscoplastic":
            continue
        if first is None:
            first = name, material.yield_function
        elif material.yield_function != first[1]:
            raise SceneError(f"materials.{name}.yield_function",
                             f"all viscoplastic materials of a scene share one yield function, "
                             f"materials.{first[0]} has {show(first[1])}, got {show(material.yield_function)}")


def mixture_density(material: Material) -> float:
    """Saturated mixture density (1 − n) ρ_s + n ρ_w [kg/m³] of a material with ``grain_density``."""
    n = material.porosity
    return (1.0 - n) * material.grain_density + n * material.water_density


def check_modulus(key: str, value: float) -> None:
    """Raise unless the modulus ``value`` [Pa] is positive (inf allowed) and not written in kPa or MPa."""
    check_range(key, value, POSITIVE)
    if value < MIN_MODULUS:
        raise SceneError(
            key, f"must be >= 1000 Pa: moduli are in Pa, not kPa or MPa (30 MPa is 30e6), got {show(value)}"
        )


def needs_pore_water(key: str, effects: Effects, what: str) -> None:
    if not effects.pore_water:
        raise SceneError(key, f"{what}needs effects.pore_water = true")


def needs_plasticity(key: str, effects: Effects, what: str) -> None:
    if not effects.plasticity:
        raise SceneError(key, f"{what}needs effects.plasticity = true")
