"""Scoreboard cases of soil brought to failure or to rest: the elastic 2:1 slope's gravity equilibrium and
Prandtl's footing pushed into von Mises soil at a coarse spacing (docs/stability.md, *Scoreboard*)."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

import warpsph
from warpsph.errors import SimulationError
from warpsph.runner import Run
from warpsph.scene import Body, Boundary, Material, Phase, Probe, Scene, Simulation
from warpsph.stability.board import Measure, case, configure, without_stabilisation
from warpsph.stability.tools import force_at_rest
from warpsph.study.metrics import (FOOTING_PRESSURE, FOOTING_SETTLEMENT, FOOTING_WINDOW, footing_end,
                                   footing_parts, footing_plateau, footing_scene)  # fmt: skip
from warpsph.validation.report import shipped_scene

G = 9.81
"""Gravity [m/s²]."""
SLOPE = [(0, 0), (8, 0), (8, 3), (6, 3), (2, 1), (0, 1)]
"""A 2:1 slope 2 m high on 1 m of ground [m] (tests/test_phases.py)."""
SLOPE_DENSITY, SLOPE_AREA, SLOPE_DX = 2000.0, 16.0, 0.2
"""The slope's soil density [kg/m³], the polygon's area [m²] and the lattice spacing [m]."""
SLOPE_TOLERANCE, SLOPE_MAX_STEPS = 1e-7, 15000
"""The equilibrium phase's unbalanced-force ratio [-] and step cap."""
SLOPE_REACTION_LIMIT = 3e-3
"""|base reaction / weight − 1| the slope at rest should reach [-]."""
FOOTING_DX = 0.1
"""The footing's lattice spacing [m]."""
FOOTING_PLATEAU_LIMIT = 0.1
"""|plateau / ((2 + π) c_u) − 1| the footing should reach [-]."""


def _energy_error(phase: dict) -> float | None:
    """A phase's energy balance |error| over the energy turned over, None where it books none."""
    return phase["energy"]["error_ratio"] if phase.get("energy") else None


def slope_scene() -> Scene:
    """The elastic 2:1 slope (ρ = 2000 kg/m³, E = 20 MPa, ν = 0.3) on a fixed base, slip sides at x = 0
    and 8 m, brought to rest under gravity by one equilibrium phase, its base reaction probed."""
    scene = Scene(name="slope_equilibrium",
                  simulation=Simulation(dim=2, dx=SLOPE_DX, end_time=1.0, gravity=(0.0, -G, 0.0)),
                  materials={"soil": Material("soil", density=SLOPE_DENSITY, youngs_modulus=2e7, poisson_ratio=0.3)},
                  bodies=[Body("ground", "soil", shape="polygon", vertices=SLOPE)],
                  boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", 0.0, "min"),
                              Boundary("right", "slip", "x", 8.0, "max")],
                  probes=[Probe("base_reaction", kind="reaction", field="y", boundary="base")],
                  phases=[Phase("gravity", kind="equilibrium", tolerance=SLOPE_TOLERANCE,
                                max_steps=SLOPE_MAX_STEPS)])  # fmt: skip
    scene.output.usd = scene.output.xdmf = False
    scene.output.frame_interval = 1e3
    return scene


@case("slope_equilibrium", "2:1 slope brought to rest under gravity")
def slope_equilibrium(options: Mapping[str, object]) -> list[Measure]:
    """The slope's equilibrium phase: the unbalanced-force ratio it ends at, and its base reaction
    against its weight ρ g A."""
    scene = configure(slope_scene(), options)
    with tempfile.TemporaryDirectory(prefix="warpsph-slope-") as out:
        run = Run(scene, out)
        summary = run.run()
        _, reaction = warpsph.load_results(Path(out) / "results.h5").series("base_reaction")
        unbalanced = force_at_rest(run.model, run.state) / (SLOPE_DENSITY * G * SLOPE_AREA)
    phase = summary.phases[0]
    energy = _energy_error(phase)
    signed = float(reaction[-1]) / (SLOPE_DENSITY * G * SLOPE_AREA) - 1.0
    return [Measure("unbalanced-force ratio reached", phase["criterion"], SLOPE_TOLERANCE, energy_error=energy,
                    detail=f"{phase['outcome']} after {phase['steps']} steps"),
            Measure("base reaction / weight − 1", abs(signed), SLOPE_REACTION_LIMIT,
                    detail=f"{signed:+.4g} (reaction {reaction[-1]:.6g} N/m)"),
            Measure("real particles' force at rest / weight", unbalanced, SLOPE_TOLERANCE,
                    detail="one undamped, unfiltered step from the state reached, every velocity zero")]  # fmt: skip


@case("prandtl_footing", "Prandtl's footing pushed to 40 mm at Δx = 0.1 m")
def prandtl_footing(options: Mapping[str, object]) -> list[Measure]:
    """scenes/footing_prandtl.toml without its stabilisation at Δx = 0.1 m, pushed until the settlement
    reaches the top of ``FOOTING_WINDOW``: the settlement reached, and the plateau of the footing
    pressure over the window against (2 + π) c_u. A run the guard stops is measured up to where it
    stopped."""
    scene = without_stabilisation(shipped_scene("footing_prandtl"))
    scene.simulation.dx = FOOTING_DX
    scene = footing_scene(configure(scene, options))
    end = footing_end(scene)
    stopped, energy = "", None
    with tempfile.TemporaryDirectory(prefix="warpsph-footing-") as out:
        try:
            summary = warpsph.run_scene(scene, out, end_time=end)
            energy = _energy_error(summary.phases[-1])
        except SimulationError as error:
            stopped = str(error).partition("; the last good checkpoint")[0]
        results = warpsph.load_results(Path(out) / "results.h5")
        names = results.series_names
        times, settlement = results.series(FOOTING_SETTLEMENT) if FOOTING_SETTLEMENT in names else ((), ())
        _, pressure = results.series(FOOTING_PRESSURE) if FOOTING_PRESSURE in names else ((), ())
        if stopped and "energy_error_ratio" in names:  # the balance at the last check before the stop
            energy = float(results.series("energy_error_ratio")[1][-1])
    finite = np.asarray(settlement, dtype=float)[np.isfinite(settlement)]
    reached = 1e3 * float(finite.max()) if finite.size else 0.0
    plateau, spread, count = footing_plateau(settlement, pressure, FOOTING_WINDOW)
    prandtl = (2.0 + math.pi) * footing_parts(scene)[0].cohesion
    signed = plateau / prandtl - 1.0
    last = f"last sample t = {times[-1]:.4g} s" if len(times) else "no sample"
    where = f"stopped ({last} of {end:.4g} s): {stopped}" if stopped else f"ran to t = {end:.4g} s"
    window = f"{1e3 * FOOTING_WINDOW[0]:g}-{1e3 * FOOTING_WINDOW[1]:g} mm"
    return [Measure("settlement reached [mm]", reached, 1e3 * FOOTING_WINDOW[1], below=False, energy_error=energy,
                    detail=where),
            Measure("plateau / (2+π)c_u − 1", abs(signed), FOOTING_PLATEAU_LIMIT,
                    detail=(f"{signed:+.4g} over {window} ({count} samples, spread {spread / prandtl:.3g})" if count
                            else f"no sample in {window}"))]  # fmt: skip
