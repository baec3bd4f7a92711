"""Permeability contrast (issue 6, item 6): two layers whose k_h differ by 1e6 (two-set scheme only).

A 10 m saturated column (Terzaghi set A material, Δx = 0.2 m): sand (k_h = 1e-3 m/s) from 5 to 10 m
over clay (k_h = 1e-9 m/s), one body per layer, each with its own material; started from the
undrained state under σ₀ = 5 kPa (p₀ = σ₀Q/(Q + E_oed), as ``test_terzaghi``), top drained, base
impermeable, run through :class:`warpsph.runner.Run` to T_v = 0.3 of the sand layer (3400 steps).

Closed form (c_v of the clay is 1e6 times smaller, its boundary layer √(c_v t) ≈ 2 mm ≪ Δx): the sand
consolidates as a Terzaghi layer of H = 5 m on an impermeable base, the clay keeps p₀.

Criteria: the CG solve converges within its cap (1000) at every step (the ``pressure_iterations`` and
``pressure_residual`` series, and run.json); the pressure stays within [0, 1.01 p₀]; the clay holds
p₀ within 2 %, the sand is within 1 % (L2) of its closed form and the jump between the two particles
straddling the interface is the closed form's within 2 % of p₀ (the clay's boundary layer, 2 mm, is
far below Δx, so at this resolution the continuous pressure is a jump from the sand's base value to
p₀) — the clay and the jump measured to miss at the default Courant number 0.5 and met at Δx = 0.1 m
and Courant 0.25 (docs/stability.md).
"""

import json

import numpy as np
import pytest
from stability_tools import expected_failure
from test_terzaghi import SIGMA0

from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.scene import Body, Boundary, Drainage, Effects, Load, Material, Output, PressureSolver, Scene, Simulation
from warpsph.verification import consolidation_constants, terzaghi_pressure

HEIGHT, INTERFACE, DX = 10.0, 5.0, 0.2
TIME_FACTOR = 0.3


def layer(name: str, conductivity: float) -> Material:
    return Material(name, density=1700.0, youngs_modulus=30e6, poisson_ratio=0.2, porosity=0.3,
                    grain_density=2000.0, water_bulk_modulus=100e6, hydraulic_conductivity=conductivity)  # fmt: skip


SAND, CLAY = layer("sand", 1e-3), layer("clay", 1e-9)
P0, CV, _, _ = consolidation_constants(SAND, HEIGHT - INTERFACE, SIGMA0)


def run_layers(out, dx: float = DX, courant: float = 0.5, interior_stabilisation: float = 0.0):
    """Run the layered column into ``out``; (results, run record, initial heights y [m] sorted, final pore
    pressure [Pa] in that order, scene)."""
    vertical = -(SIGMA0 - P0)
    stress = (0.25 * vertical, vertical, 0.25 * vertical, 0.0, 0.0, 0.0)
    end = TIME_FACTOR * (HEIGHT - INTERFACE) ** 2 / CV
    scene = Scene(
        simulation=Simulation(dim=1, dx=dx, end_time=end, courant=courant), effects=Effects(pore_water=True),
        materials={"sand": SAND, "clay": CLAY},
        bodies=[Body("sand", "sand", min=(0, INTERFACE, 0), max=(0, HEIGHT, 0), pore_pressure=P0, stress=stress),
                Body("clay", "clay", min=(0, 0, 0), max=(0, INTERFACE, 0), pore_pressure=P0, stress=stress)],
        boundaries=[Boundary("base", "fixed", "y", 0.0, "min")],
        loads=[Load("top", "traction", "y", HEIGHT, "max", traction=(0, -SIGMA0, 0), drainage=Drainage("drained"))],
        pressure=PressureSolver(tolerance=1e-10, max_iterations=1000, interior_stabilisation=interior_stabilisation),
        output=Output(frame_interval=end, fields=["pore_pressure"], usd=False, xdmf=False),
    ).validate()  # fmt: skip
    Run(scene, out).run()
    results = load_results(out / "results.h5")
    y = results.frame(0)["position"][:, 1]  # initial heights: layers by where particles started
    order = np.argsort(y)
    pressure = results.frame(len(results) - 1)["pore_pressure"]
    return results, json.loads((out / "run.json").read_text()), y[order], pressure[order], scene


@pytest.fixture(scope="module")
def layered(tmp_path_factory):
    return run_layers(tmp_path_factory.mktemp("layered"))


def test_cg_converges_within_its_cap_every_step(layered):
    results, record, _, _, scene = layered
    _, iterations = results.series("pressure_iterations")
    _, residuals = results.series("pressure_residual")
    print(f"\nlayered column: {len(iterations)} solves, CG iterations mean {np.mean(iterations):.1f}, max "
          f"{int(np.max(iterations))}, largest relative residual {np.max(residuals):.2e}")
    assert len(iterations) == record["steps"]
    assert np.max(iterations) < scene.pressure.max_iterations
    assert np.max(residuals) <= scene.pressure.tolerance
    assert record["pressure_solve"]["missed_tolerance"] == 0


def test_pressure_stays_between_drained_and_undrained(layered):
    _, _, y, p, _ = layered
    print(f"\np/p₀ in [{p.min() / P0:.4f}, {p.max() / P0:.4f}]")
    assert p.min() >= 0.0 and p.max() <= 1.01 * P0


def against_the_closed_form(results, y, p):
    """(sand L2 error / p₀, largest |p/p₀ − 1| in the clay, jump across the interface and its closed
    form [Pa]) at the last frame, printed."""
    tv = CV * results.times[-1] / (HEIGHT - INTERFACE) ** 2
    sand = y >= INTERFACE - 1e-9
    l2 = np.sqrt(np.mean((p[sand] - terzaghi_pressure(HEIGHT - y[sand], HEIGHT - INTERFACE, P0, tv)) ** 2)) / P0
    clay = np.abs(p[~sand] / P0 - 1.0)
    across = np.argmax(sand) - 1  # the jump between the clay's top and the sand's bottom
    jump = p[across + 1] - p[across]
    exact_jump = terzaghi_pressure(HEIGHT - INTERFACE, HEIGHT - INTERFACE, P0, tv) - P0
    print(f"\nT_v = {tv:.3f}: sand L2 {l2:.2e} p₀, clay off p₀ by up to {clay.max():.4f} p₀ "
          f"(rows {np.round(p[~sand][-3:] / P0, 4)} below the interface), jump across it {jump / P0:.3f} p₀ "
          f"(closed form {exact_jump / P0:.3f}: the clay's 2 mm boundary layer is far below Δx)")
    return l2, clay.max(), jump, exact_jump


@expected_failure("the clay's row next to the sand reads 0.975 p₀ (2.5 % off; the sand is within 0.99 % L2) and "
                  "the jump across the interface is -0.348 p₀ for -0.393: a splitting error of the projection's "
                  "Δt/ρ part at the kink of the pressure increment, as C² (0.910 at C = 0.9), not Δx (0.971 and "
                  "0.969 at Δx = 0.1 and 0.05 m); the jump's error is the sand's base row, 2 % high, first order "
                  "in Δx (measured, docs/stability.md)")
def test_layers_against_the_closed_form(layered):
    results, _, y, p, _ = layered
    l2, clay, jump, exact_jump = against_the_closed_form(results, y, p)
    assert clay < 0.02
    assert l2 < 0.01
    assert abs(jump - exact_jump) < 0.02 * P0


def test_layers_against_the_closed_form_at_half_the_courant_number(tmp_path):
    """What the contrast costs: at Δx = 0.1 m and Courant 0.25 (4× the steps, 13 600) with the interior
    roughness weight 0.02, which damps an odd-even ripple the interface sends into the clay (without
    it the clay reaches 1.0115 p₀ and 0.984 p₀), the criteria above are met: the pressure within
    [0, 1.01 p₀], the clay within 2 % of p₀, the sand within 1 % (L2) and the jump within 2 % p₀ of
    the closed form."""
    results, record, y, p, _ = run_layers(tmp_path, dx=0.1, courant=0.25, interior_stabilisation=0.02)
    l2, clay, jump, exact_jump = against_the_closed_form(results, y, p)
    assert record["pressure_solve"]["missed_tolerance"] == 0
    assert p.min() >= 0.0 and p.max() <= 1.01 * P0
    assert clay < 0.02
    assert l2 < 0.01
    assert abs(jump - exact_jump) < 0.02 * P0
