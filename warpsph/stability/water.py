"""The scoreboard's saturated cases: the loaded strip at low permeability (its excess pore pressure's bound)
and the 2D consolidation of a strip-loaded layer (whether its implicit steps converge)."""

from __future__ import annotations

import tempfile
from collections.abc import Mapping

import numpy as np

from warpsph.runner import Run
from warpsph.scene import (Body, Boundary, Drainage, Effects, Load, Material, Phase, PressureSolver, Region, Scene,
                           Simulation, TimeFunction)  # fmt: skip
from warpsph.stability.board import Measure, case, configure
from warpsph.stability.tools import balance_error, march

STRIP_Q, STRIP_RAMP, STRIP_END = 50e3, 0.1, 1.5
"""The loaded strip's footing pressure q [Pa], its ramp [s] and the run's end [s]."""
RISE_TOLERANCE = 0.02
"""The rise of the strip's largest excess pore pressure once the load is on that still holds, over q [-]: at
the shipped k_h = 1e-3 m/s, where the excess drains, it still rises 0.011 q within 0.01 s of the ramp's end,
as the block's response catches up with the load."""


def loaded_strip(hydraulic_conductivity: float = 1e-5) -> Scene:
    """scenes/strip_footing.toml cut to a 3 m × 2 m block at Δx = 0.25 m (the stability suite's loaded
    strip): q = 50 kPa on |x| ≤ 1.125 m ramped over 0.1 s, sealed under the footing and drained beside
    it, geostatic start, water table at the top, to 1.5 s; no probes, no artificial viscosity."""
    soil = Material("soil", density=1700.0, youngs_modulus=30e6, poisson_ratio=0.2, porosity=0.3,
                    grain_density=2000.0, water_density=1000.0, water_bulk_modulus=2.2e9,
                    hydraulic_conductivity=hydraulic_conductivity)  # fmt: skip
    impermeable = Drainage("impermeable")
    return Scene(
        name="loaded_strip",
        simulation=Simulation(dim=2, dx=0.25, end_time=STRIP_END, courant=0.5, gravity=(0.0, -9.81, 0.0)),
        effects=Effects(pore_water=True), materials={"soil": soil},
        bodies=[Body("layer", "soil", min=(0.0, 0.0, 0.0), max=(3.0, 2.0, 0.0), geostatic=True)],
        boundaries=[Boundary("base", "slip", "y", 0.0, "min", drainage=impermeable),
                    Boundary("centre", "symmetry", "x", 0.0, "min"),
                    Boundary("far_side", "slip", "x", 3.0, "max", drainage=impermeable)],
        loads=[Load("footing", "traction", "y", 2.0, "max", traction=(0.0, -STRIP_Q, 0.0),
                    extent=Region((-1.125, 1.0, 0.0), (1.125, 3.0, 0.0)),
                    time_function=TimeFunction("ramp", duration=STRIP_RAMP),
                    drainage=Drainage("drained", extent=Region((1.125, 1.0, 0.0), (4.0, 3.0, 0.0))))],
        pressure=PressureSolver(solver="cg", tolerance=1e-8, water_table=2.0),
    )  # fmt: skip


@case("saturated_strip", "strip load on saturated soil at k_h = 1e-5 m/s")
def saturated_strip(options: Mapping[str, object]) -> list[Measure]:
    """The loaded strip at k_h = 1e-5 m/s to 1.5 s: its largest |excess pore pressure| over q (bound
    1.2), and how much that largest excess still rises after the load is fully on, over q (none,
    up to ``RISE_TOLERANCE``: once loaded, the excess only drains away)."""
    scene = configure(loaded_strip(), options)
    dt = scene.time_step
    peaks = []

    def excess_peak(k, model, state):
        p = state.particle_pore_pressure.numpy()[: model.particle_count]  # the excess over hydrostatic
        peaks.append(float(np.abs(p).max()))
        return bool(np.isfinite(p).all())

    balance = {}
    steps = int(round(STRIP_END / dt))
    model, _, _ = march(scene, steps, excess_peak, balance=balance)
    peaks = np.array(peaks)
    loaded = int(np.ceil(STRIP_RAMP / dt * (1.0 - 1e-9)))  # the first step with the load fully on
    finished = len(peaks) == steps + 1
    largest = float(np.max(peaks)) if finished else np.nan
    rise = float(np.max(peaks[loaded:]) - peaks[loaded]) if finished else np.nan
    samples = ", ".join(f"{peaks[k] / 1e3:.1f}" for k in np.linspace(0, steps, 7).astype(int)[1:] if k < len(peaks))
    detail = (f"{model.particle_count} particles, {len(peaks) - 1} of {steps} steps of {dt:.3g} s; largest |excess| "
              f"{samples} kPa at 0.25-1.5 s, {peaks[min(loaded, len(peaks) - 1)] / 1e3:.1f} kPa at full load "
              f"({loaded * dt:.3g} s), largest {np.max(peaks) / 1e3:.1f} kPa at {np.argmax(peaks) * dt:.3g} s")
    error = balance_error(balance)
    return [Measure("largest excess pore pressure / q", largest / STRIP_Q, 1.2, energy_error=error, detail=detail),
            Measure("rise once loaded / q", rise / STRIP_Q, RISE_TOLERANCE, energy_error=error, detail=detail)]


CLAY = Material("clay", density=2020.0, youngs_modulus=10e6, poisson_ratio=0.3, porosity=0.4, grain_density=2700.0,
                water_density=1000.0, water_bulk_modulus=2.2e9, hydraulic_conductivity=1e-8)  # fmt: skip
"""A soft clay with real water (Skempton's B ≈ 1): E_oed = 13.5 MPa, c_v = 1.37e-5 m²/s."""
LAYER_Q, LAYER_TV = 20e3, 0.05
"""The consolidating layer's strip load q [Pa] and the time factor c_v t / H² its phase runs to [-]."""
FAILED_TRIES = 3
"""Implicit steps whose fixed-stress iteration fails (each up to 30 equilibria) after which the case stops."""


def strip_loaded_layer(width: float = 3.0, depth: float = 1.5, dx: float = 0.25, material: Material = CLAY) -> Scene:
    """Half a plane-strain saturated elastic layer ``width`` × ``depth`` [m] without gravity: q = 20 kPa on
    its top over a quarter of its width (edge on the virtual-point column ½Δx beyond the last loaded
    particle), the whole top drained, a fixed impermeable base, a symmetry plane at x = 0 and a slip side;
    one consolidation phase to T_v = ``LAYER_TV`` (H = ``depth``) from the load's undrained jump."""
    cv = material.hydraulic_conductivity / (material.water_density * 9.81
                                            * (1.0 / material.oedometric_modulus + 1.0 / material.biot_modulus))
    duration = LAYER_TV * depth**2 / cv
    scene = Scene(
        name="strip_loaded_layer", simulation=Simulation(dim=2, dx=dx), effects=Effects(pore_water=True),
        materials={material.name: material},
        bodies=[Body("layer", material.name, min=(0.0, 0.0, 0.0), max=(width, depth, 0.0))],
        boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("centre", "symmetry", "x", 0.0, "min"),
                    Boundary("side", "slip", "x", width, "max")],
        loads=[Load("strip", "traction", "y", depth, "max", traction=(0.0, -LAYER_Q, 0.0),
                    extent=Region((-1.0, depth - 1.0, 0.0), (width / 4 + dx / 2, depth + 1.0, 0.0)),
                    drainage=Drainage("drained"))],
        phases=[Phase("consolidation", "consolidation", duration=duration, frames=1, time_step=duration / 20)],
    )  # fmt: skip
    scene.output.usd = scene.output.xdmf = False
    scene.output.fields = ["displacement", "pore_pressure"]
    return scene


class _Capped(Exception):
    """``FAILED_TRIES`` implicit steps of the consolidation failed: the run is stopped."""


@case("consolidation_2d", "2D consolidation of a strip-loaded layer")
def consolidation_2d(options: Mapping[str, object]) -> list[Measure]:
    """The strip-loaded clay layer's consolidation phase: the tries of an implicit step whose fixed-stress
    iteration converged, over all tries (1 where it converges; a stalled iteration fails its 30 equilibria
    and is retried at half the step), and the phase time reached over its duration (1 where it finishes;
    0 where even the undrained first step never converges). Stopped after ``FAILED_TRIES`` failed tries:
    the runner would halve the step some forty times, minutes each, before giving up itself."""
    scene = configure(strip_loaded_layer(), options)
    duration = scene.phases[0].duration
    tries = []  # (phase time at the try's start [s], Δt [s], converged, fixed-stress iterations)
    with tempfile.TemporaryDirectory(prefix="warpsph-board-") as out:
        run = Run(scene, out)
        split = run.split
        solve = split.solve

        def counted(t: float, dt: float) -> bool:
            converged = solve(t, dt)
            tries.append((t - dt, dt, converged, split.iterations))
            if sum(not c for _, _, c, _ in tries) >= FAILED_TRIES:
                raise _Capped
            return converged

        split.solve = counted
        try:
            status, reached = run.run().status, run.phase_time
        except _Capped:  # the state is back at the start of the last try
            status, reached = f"stopped after {FAILED_TRIES} failed tries", tries[-1][0]
        particles = run.model.particle_count
    converged = sum(c for _, _, c, _ in tries)
    shown = ", ".join(f"{dt:.3g} s {'✓' if c else '✗'}{i}" for _, dt, c, i in tries[:8])
    shown += " …" if len(tries) > 8 else ""
    detail = (f"{particles} particles, {status}: {converged} of {len(tries)} tries of an implicit step converged "
              f"(Δt, ✓/✗ and fixed-stress iterations: {shown}); t = {reached:.4g} of {duration:.4g} s")
    return [Measure("converged implicit steps / tries", converged / max(len(tries), 1), 1.0, below=False,
                    detail=detail),
            Measure("phase time reached / duration", reached / duration, 1.0, below=False, detail=detail)]
