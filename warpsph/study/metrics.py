"""Error metrics of the accuracy studies: scenes with closed-form answers (docs/accuracy.md).

A :class:`Metric` runs a scene in memory (:func:`warpsph.verification.run_sampled`) and measures
its errors against the closed form: dimensionless, ≥ 0, smaller is better. Register a new one with
:func:`register`; ``PLANNED_METRICS`` names those that need a later version (a study asking for
one gets that reason as its error).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from warpsph.errors import SceneError
from warpsph.scene import Scene
from warpsph.verification import (SampledRun, column_stress_run, consolidation_constants, pressure_l2, run_sampled,
                                  step_wave_metrics)  # fmt: skip

SECONDS_PER_STEP = 2.0e-3
"""Launch cost of a step on the 2-core CPU, whatever its size [s] (for :meth:`Metric.estimated_seconds`)."""
PARTICLE_STEPS_PER_SECOND = 3.0e5
"""Throughput of the 2D step on the 2-core CPU (docs/performance.md)."""


@dataclass
class Measurement:
    """What a metric measured on one run."""

    run: SampledRun
    errors: dict[str, float]
    """Error name → value (dimensionless, ≥ 0)."""
    extras: dict[str, float]
    """Further measures worth a column, not errors (e.g. the plateau level)."""


@dataclass(frozen=True)
class Metric:
    """A closed-form comparison a study can sweep settings against."""

    name: str
    description: str
    errors: dict[str, str]
    """Error name → what it is; the first is the default error of a study's Pareto front."""
    check: Callable[[Scene], None]
    """Raises :class:`SceneError` (key ``study.metric``) when the scene does not fit the closed form."""
    end_time: Callable[[Scene], float]
    """Simulated time a run of the scene needs [s]."""
    measure: Callable[[Scene, str], Measurement]
    """(scene, device) → :class:`Measurement`."""

    @property
    def default_error(self) -> str:
        return next(iter(self.errors))

    def estimated_seconds(self, scene: Scene) -> float:
        """Rough CPU time [s] of a run: steps × (launch cost + particles / throughput)."""
        from warpsph.lattice import fill_body

        particles = sum(len(fill_body(body, scene.simulation.dx, scene.simulation.dim)) for body in scene.bodies)
        steps = self.end_time(scene) / scene.time_step
        return steps * (SECONDS_PER_STEP + particles / PARTICLE_STEPS_PER_SECOND)


METRICS: dict[str, Metric] = {}
PLANNED_METRICS = {
    "prandtl_footing": "the limit-load error of the Prandtl strip footing needs the plasticity effect, which is "
                       "not available in this version of warpsph",
}  # fmt: skip


def register(metric: Metric) -> Metric:
    """Make ``metric`` available to study files under its name."""
    METRICS[metric.name] = metric
    PLANNED_METRICS.pop(metric.name, None)
    return metric


def loaded_column(scene: Scene, metric: str) -> tuple[float, float]:
    """(height H [m], σ₀ [Pa]) of a column scene: one box body from y = 0 to H with a compressive
    traction σ₀ on its top face (axis y, side max, at y = H); otherwise :class:`SceneError`."""
    body = scene.bodies[0] if len(scene.bodies) == 1 else None
    if body is None or body.shape != "box" or body.min[1] != 0.0:
        raise SceneError("study.metric", f"{metric} needs one box body with its base at y = 0")
    height = body.max[1]
    top = [ld for ld in scene.loads if ld.kind == "traction" and ld.axis == "y" and ld.side == "max"
           and ld.position == height and ld.traction[1] < 0]  # fmt: skip
    if len(top) != 1:
        raise SceneError("study.metric", f"{metric} needs a compressive traction load on the top face y = {height:g}")
    return height, -top[0].traction[1]


# -------------------------------------------------------------------------------- wave column
WAVE_END = 0.7
"""Runs stop when the front is this fraction of the height down (step_wave_metrics uses 30-70 %)."""


def _check_wave(scene: Scene) -> None:
    loaded_column(scene, "wave_column")
    if scene.effects.pore_water:
        raise SceneError("study.metric", "wave_column needs a dry scene (effects.pore_water = false)")


def _wave_end(scene: Scene) -> float:
    height, _ = loaded_column(scene, "wave_column")
    return WAVE_END * height / scene.max_p_wave_speed


def _measure_wave(scene: Scene, device: str) -> Measurement:
    height, sigma0 = loaded_column(scene, "wave_column")
    speed = scene.max_p_wave_speed
    run = column_stress_run(scene, _wave_end(scene), device=device)
    m = step_wave_metrics(run.times, run.samples, height=height, speed=speed, sigma0=sigma0, dx=scene.simulation.dx)
    errors = {"profile_l2": m.l2_error, "front_speed_error": abs(m.front_speed / speed - 1.0)}
    return Measurement(run, errors, {"plateau_mean": m.plateau_mean, "overshoot": m.overshoot})


register(Metric(
    name="wave_column",
    description="step-loaded elastic column: the stress step travelling down at c_p (verification.step_wave_metrics)",
    errors={"profile_l2": "RMS of −σ_yy/σ₀ minus the exact step over the column, front 70 % down",
            "front_speed_error": "|front speed / c_p − 1|, front speed from the loaded length ∫−σ_yy/σ₀ dy"},
    check=_check_wave, end_time=_wave_end, measure=_measure_wave))  # fmt: skip


# -------------------------------------------------------------------------------- Terzaghi
TERZAGHI_TV = (0.1, 0.3, 0.5)
"""Time factors T_v = c_v t/H² at which the pore-pressure profile is compared."""


def _terzaghi(scene: Scene):
    """(H [m], Consolidation) of a Terzaghi column scene."""
    height, sigma0 = loaded_column(scene, "terzaghi")
    if not scene.effects.pore_water:
        raise SceneError("study.metric", "terzaghi needs effects.pore_water = true")
    return height, consolidation_constants(scene.materials[scene.bodies[0].material], height, sigma0)


def _check_terzaghi(scene: Scene) -> None:
    _terzaghi(scene)


def _terzaghi_end(scene: Scene) -> float:
    height, consolidation = _terzaghi(scene)
    return max(TERZAGHI_TV) * height**2 / consolidation.cv


def _excess_pore_pressure(model, state) -> np.ndarray:
    return state.particle_pore_pressure.numpy()[: model.particle_count].astype(np.float64)


def _measure_terzaghi(scene: Scene, device: str) -> Measurement:
    height, consolidation = _terzaghi(scene)
    dt, cv = scene.time_step, consolidation.cv
    run = run_sampled(scene, [round(tv * height**2 / cv / dt) for tv in TERZAGHI_TV], _excess_pore_pressure, device)
    zeta = height - run.model.particle_x0[:, 1]
    at = {f"pressure_l2_tv{tv:g}": pressure_l2(p, zeta, height, consolidation.p0, cv * t / height**2)
          for tv, t, p in zip(TERZAGHI_TV, run.times, run.samples)}  # fmt: skip
    return Measurement(run, {"pressure_l2": max(at.values()), **at}, {})


register(Metric(
    name="terzaghi",
    description="Terzaghi consolidation of a saturated column from the undrained state "
                "(verification.terzaghi_pressure)",
    errors={"pressure_l2": "largest of the pressure_l2_tv* errors",
            **{f"pressure_l2_tv{tv:g}": f"RMS of p − p_Terzaghi over the particles at T_v = {tv:g}, over p₀"
               for tv in TERZAGHI_TV}},
    check=_check_terzaghi, end_time=_terzaghi_end, measure=_measure_terzaghi))  # fmt: skip
