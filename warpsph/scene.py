"""Scene description: a :class:`Scene` of the plain dataclasses (:mod:`warpsph.scene_sections`, all
importable from here) that a TOML scene file and the Python API both produce, in SI units;
:mod:`warpsph.builder` turns it into device arrays, ``Scene.validate()`` checks it (docs/scenes.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from warpsph.scene_check import validate_scene
from warpsph.scene_sections import (AXES, EXTENT_TOLERANCE, FAILURE_DISPLACEMENT, IMPLICIT_PHASE_KINDS, PHASE_KINDS,
                                    STANDARD_GRAVITY, Body, Boundary, Drainage, Effects, Load, Material, Output,
                                    Phase, PressureSolver, Probe, Region, Reservoir, Simulation,
                                    TimeFunction)  # fmt: skip

__all__ = ["AXES", "EXTENT_TOLERANCE", "FAILURE_DISPLACEMENT", "IMPLICIT_PHASE_KINDS", "PHASE_KINDS", "STANDARD_GRAVITY",
           "Body", "Boundary", "Drainage", "Effects", "Load", "Material", "Output", "Phase", "PressureSolver", "Probe",
           "Region", "Reservoir", "Scene", "Simulation", "TimeFunction"]


@dataclass
class Scene:
    """A complete simulation set-up."""

    name: str = "scene"
    simulation: Simulation = field(default_factory=Simulation)
    effects: Effects = field(default_factory=Effects)
    materials: dict[str, Material] = field(default_factory=dict)
    bodies: list[Body] = field(default_factory=list)
    boundaries: list[Boundary] = field(default_factory=list)
    loads: list[Load] = field(default_factory=list)
    probes: list[Probe] = field(default_factory=list)
    pressure: PressureSolver = field(default_factory=PressureSolver)
    output: Output = field(default_factory=Output)
    reservoirs: list[Reservoir] = field(default_factory=list)
    """Free water against the free surfaces."""
    phases: list[Phase] = field(default_factory=list)
    """Staged analysis: the phases in order; none runs one dynamic phase to ``simulation.end_time``."""
    source_text: str = ""
    """The scene file's text, stored in results for provenance (empty for Python-built scenes)."""

    @property
    def smoothing_length(self) -> float:
        """h [m]."""
        return self.simulation.smoothing_ratio * self.simulation.dx

    @property
    def max_p_wave_speed(self) -> float:
        """Largest drained P-wave speed of the materials in use [m/s]."""
        used = {b.material for b in self.bodies}
        return max(self.materials[m].p_wave_speed for m in used)

    @property
    def speed_limit(self) -> float:
        """The run guard's speed bound [m/s]: ``simulation.velocity_limit``, by default the largest
        P-wave speed. The time step resolves waves at that speed; no soil particle moves at it, so one
        that does has blown up (a footing thrown off at 68 m/s for c_p = 82 m/s, docs/stability.md)."""
        limit = self.simulation.velocity_limit
        return self.max_p_wave_speed if limit is None else limit

    @property
    def speed_limit_text(self) -> str:
        """Where :attr:`speed_limit` comes from, for messages."""
        if self.simulation.velocity_limit is None:
            return f"the largest P-wave speed {self.speed_limit:.4g} m/s (the default of simulation.velocity_limit)"
        return f"simulation.velocity_limit = {self.speed_limit:g} m/s"

    @property
    def yield_function(self) -> str:
        """The yield function of the viscoplastic materials with the plasticity effect (validation
        allows one per scene; "von_mises" if no material is viscoplastic), "" without the effect."""
        if not self.effects.plasticity:
            return ""
        names = [m.yield_function for m in self.materials.values() if m.model == "viscoplastic"]
        return names[0] if names else "von_mises"

    @property
    def time_step(self) -> float:
        """Δt = C Δx / c_p [s]."""
        return self.simulation.courant * self.simulation.dx / self.max_p_wave_speed

    def validate(self) -> Scene:
        """Check the scene and type its phases' changes; raise :class:`warpsph.errors.SceneError`
        naming the key path."""
        validate_scene(self)
        return self
