"""Error metrics of the accuracy studies: scenes with closed-form answers (docs/accuracy.md).

A :class:`Metric` runs a scene in memory (:func:`warpsph.verification.run_sampled`) and measures
its errors against the closed form: dimensionless, ≥ 0, smaller is better. Register a new one with
:func:`register`; ``PLANNED_METRICS`` names those that need a later version (a study asking for
one gets that reason as its error).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from warpsph.errors import SceneError, SimulationError
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
PLANNED_METRICS: dict[str, str] = {}
"""Metric name → why this version cannot measure it (a study naming one is refused with the reason)."""


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


# -------------------------------------------------------------------------------- Prandtl footing
FOOTING_PRESSURE, FOOTING_SETTLEMENT = "footing_pressure", "footing_displacement"
"""Probes of the footing scene: the base reaction over B/2 [Pa] and the piston settlement [m]."""
FOOTING_WINDOW = (0.025, 0.040)
"""Settlement window [m] of the plateau (as tests/test_footing_prandtl.py): the pressure has levelled
off by 25 mm, and the runs at Δx = 0.05 and 0.1 m hold past 38 mm (docs/method.md, "Known limits")."""
PISTON_GAP = 0.75
"""The piston region starts this many spacings above the ground (scenes/footing_prandtl.toml)."""
PROBE_EVERY = 10
"""Steps between samples of the footing probes (the scene's output.probe_every)."""


def footing_plateau(settlement, pressure, window: tuple[float, float]) -> tuple[float, float, int]:
    """(mean, standard deviation, count) of ``pressure`` over the samples whose ``settlement`` lies in
    ``window`` (as tests/test_footing_prandtl.py); (nan, nan, 0) when none does."""
    settlement, pressure = np.asarray(settlement, dtype=float), np.asarray(pressure, dtype=float)
    inside = (settlement >= window[0]) & (settlement <= window[1])
    if not inside.any():
        return math.nan, math.nan, 0
    return float(np.mean(pressure[inside])), float(np.std(pressure[inside])), int(inside.sum())


def footing_parts(scene: Scene):
    """(soil material, footing body, velocity load, pressure probe, settlement probe) of a footing
    scene; otherwise :class:`SceneError`."""
    need = ("prandtl_footing needs the footing scene's layout (scenes/footing_prandtl.toml): plasticity on, a box "
            "body 'footing' on a von Mises soil body, a velocity load with a region and the probes "
            f"{FOOTING_PRESSURE} (reaction) and {FOOTING_SETTLEMENT} (region_mean of displacement_y)")
    if not scene.effects.plasticity or scene.effects.pore_water:
        raise SceneError("study.metric", need + ": effects.plasticity = true, dry")
    bodies = {b.name: b for b in scene.bodies}
    footing = bodies.get("footing")
    soils = [b for b in scene.bodies if b is not footing and scene.materials[b.material].yield_function == "von_mises"
             and scene.materials[b.material].cohesion > 0]  # fmt: skip
    loads = [ld for ld in scene.loads if ld.kind == "velocity" and ld.region is not None]
    probes = {p.name: p for p in scene.probes}
    pressure, settlement = probes.get(FOOTING_PRESSURE), probes.get(FOOTING_SETTLEMENT)
    if (footing is None or footing.shape != "box" or len(soils) != 1 or len(loads) != 1 or pressure is None
            or pressure.kind != "reaction" or settlement is None or settlement.kind != "region_mean"
            or settlement.field != "displacement_y" or settlement.region is None):  # fmt: skip
        raise SceneError("study.metric", need)
    if loads[0].time_function.kind not in ("constant", "ramp") or loads[0].time_function.start != 0.0:
        raise SceneError("study.metric", "prandtl_footing needs a constant or ramp (start 0) footing velocity")
    return scene.materials[soils[0].material], footing, loads[0], pressure, settlement


def footing_scene(scene: Scene) -> Scene:
    """A copy of the footing scene with its geometry following Δx, as tests/test_footing_prandtl.py
    sets it: the probe ``footing_pressure`` divides by B/2 = (last footing particle's x) + Δx/2 (the
    edge lies half a spacing beyond the last particle; 0.525 m at Δx = 0.05 m, 0.4875 m at 0.075 m),
    and the piston region (load and settlement probe) starts 3/4 Δx above the footing's base."""
    import copy

    from warpsph.lattice import fill_body

    scene = copy.deepcopy(scene)
    _, footing, load, pressure, settlement = footing_parts(scene)
    dx = scene.simulation.dx
    half_width = float(fill_body(footing, dx, scene.simulation.dim)[:, 0].max()) + 0.5 * dx
    pressure.scale = 1.0 / half_width
    for probe in scene.probes:  # the footing's own contact force, if the scene writes it
        if probe.kind == "reaction" and probe.boundary == load.name:
            probe.scale = -1.0 / half_width
    for region in (load.region, settlement.region):
        low = list(region.min)
        low[1] = footing.min[1] + PISTON_GAP * dx
        region.min = tuple(low)
    return scene


def _check_footing(scene: Scene) -> None:
    footing_parts(scene)


def footing_end(scene: Scene) -> float:
    """Time [s] at which the prescribed settlement reaches the top of the window."""
    _, _, load, _, _ = footing_parts(scene)
    speed = abs(load.velocity[1])
    ramp = load.time_function.duration if load.time_function.kind == "ramp" else 0.0
    top = FOOTING_WINDOW[1]
    if top < 0.5 * speed * ramp:  # still on the ramp: settlement v t² / (2 T)
        return math.sqrt(2.0 * ramp * top / speed)
    return 0.5 * ramp + top / speed


def _measure_footing(scene: Scene, device: str) -> Measurement:
    from warpsph.probes import Probes
    from warpsph.model import host_fields

    scene = footing_scene(scene)
    soil, _, _, _, _ = footing_parts(scene)
    limit = (2.0 + math.pi) * soil.cohesion
    probes: list[Probes] = []

    def sample(model, state):
        if not probes:
            probes.append(Probes(model))
        values = probes[0].sample(host_fields(model, state))
        return values[FOOTING_SETTLEMENT], values[FOOTING_PRESSURE]

    steps = int(math.ceil(footing_end(scene) / scene.time_step - 1e-9))
    run = run_sampled(scene, [*range(PROBE_EVERY, steps, PROBE_EVERY), steps], sample, device)
    settlement, pressure = zip(*run.samples) if run.samples else ((), ())
    window = FOOTING_WINDOW
    plateau, spread, count = footing_plateau(settlement, pressure, window)
    if count == 0:
        raise SimulationError(f"the footing settled {max(settlement, default=0.0) * 1e3:.3g} mm by the end, "
                              f"never reaching the plateau window "
                              f"{window[0] * 1e3:.3g}-{window[1] * 1e3:.3g} mm")  # fmt: skip
    ratio = plateau / limit
    return Measurement(run, {"limit_load_error": abs(ratio - 1.0)},
                       {"plateau_over_cu": plateau / soil.cohesion, "signed_error": ratio - 1.0,
                        "plateau_spread": spread / limit, "window_lo_mm": window[0] * 1e3,
                        "window_hi_mm": window[1] * 1e3})  # fmt: skip


register(Metric(
    name="prandtl_footing",
    description="Prandtl's rigid strip footing on weightless von Mises soil: the plateau of footing_pressure "
                "against (2 + π) c_u",
    errors={"limit_load_error": "|plateau / ((2 + π) c_u) − 1|, plateau the mean of footing_pressure over the "
                                "settlement window (metrics.FOOTING_WINDOW)"},
    check=_check_footing, end_time=footing_end, measure=_measure_footing))  # fmt: skip
