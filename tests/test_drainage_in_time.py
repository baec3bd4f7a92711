"""A drained face whose pore pressure changes in time, in a dynamic phase, against the closed form: a
1D column (Terzaghi's set A, H = 2 m, no gravity, unstressed) whose drained free top is raised from 0
to p₁ over t_r. Water at the pressure p₁ on a free face is water standing on it: it loads the column
by p₁ f(t), whose undrained part B p₁ f(t) (B = Q/(E_oed + Q), Skempton's loading efficiency) every
particle takes at once and whose rest, (1 − B) p₁ f(t) held at the top, diffuses in. With Duhamel's
integral of Terzaghi's series, ζ the depth below the top and M = π(2m+1)/2,

    p = p₁ [B f(t) + (1 − B)(f(t) − q/p₁)],
    q(ζ,t) = (p₁/t_r) Σ (2/M) sin(Mζ/H) (H²/(M² c_v)) [exp(−M² c_v (t − min(t, t_r))/H²) − exp(−M² c_v t/H²)]."""

import math

import numpy as np
import pytest

from warpsph.scene import Body, Boundary, Drainage, Effects, Material, Phase, PressureSolver, Scene, Simulation
from warpsph.scene_sections import TimeFunction
from warpsph.verification import consolidation_constants, run_sampled

HEIGHT, P1 = 2.0, 10e3
SOIL = Material("soil", density=1700.0, youngs_modulus=30e6, poisson_ratio=0.2, porosity=0.3, grain_density=2000.0,
                water_bulk_modulus=100e6, hydraulic_conductivity=1e-3)  # fmt: skip
B, CV = consolidation_constants(SOIL, HEIGHT, 1.0)[:2]
RAMP = 0.1 * HEIGHT**2 / CV
"""t_r: the top's pressure rises over T_v = 0.1 [s]."""


def closed_form(zeta: np.ndarray, t: float, terms: int = 200) -> np.ndarray:
    """p(ζ, t) [Pa] of the column whose top pressure ramps to P1 over RAMP."""
    q = np.zeros_like(zeta)
    for m in range(terms):
        big_m = math.pi * (2 * m + 1) / 2
        rate = big_m**2 * CV / HEIGHT**2
        q += (2 / big_m) * np.sin(big_m * zeta / HEIGHT) / rate * (
            math.exp(-rate * (t - min(t, RAMP))) - math.exp(-rate * t))  # fmt: skip
    f = min(t / RAMP, 1.0)
    return P1 * (B * f + (1.0 - B) * (f - q / RAMP))


def column(dx: float, phases: list[Phase] | None = None) -> Scene:
    top = Drainage("drained", pore_pressure=P1, time_function=TimeFunction("ramp", duration=RAMP))
    return Scene(
        simulation=Simulation(dim=1, dx=dx), effects=Effects(pore_water=True), materials={"soil": SOIL},
        bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, HEIGHT, 0))],
        boundaries=[Boundary("base", "fixed", "y", 0.0, "min"),
                    Boundary("top", "free", "y", HEIGHT, "max", drainage=top)],
        pressure=PressureSolver(solver="cg", tolerance=1e-10, max_iterations=1000), phases=phases or [],
    ).validate()  # fmt: skip


def test_closed_form_limits():
    """The series starts at zero, keeps the top at P1 f(t), the base at B P1 f(t) early on, and tends to P1."""
    zeta = np.linspace(0.0, HEIGHT, 5)
    assert np.allclose(closed_form(zeta, 1e-9 * RAMP), 0.0, atol=1e-3 * P1)
    assert closed_form(np.zeros(1), 0.5 * RAMP)[0] == pytest.approx(0.5 * P1, abs=1e-3 * P1)
    assert closed_form(np.full(1, HEIGHT), 0.5 * RAMP)[0] == pytest.approx(0.5 * B * P1, abs=1e-3 * P1)
    assert np.allclose(closed_form(zeta, 20 * HEIGHT**2 / CV), P1, atol=1e-6 * P1)


def test_a_dynamic_phase_follows_the_rising_top():
    """The dynamic saturated column at Δx = 0.1 m: the pore pressure at T_v = 0.05 (mid-ramp), 0.2 and
    0.6 within 0.2 % of P1 (L2) of the closed form (measured 9.3e-4, 8.0e-4, 2.3e-4)."""
    scene = column(0.1, [Phase(name="rising", kind="dynamic", duration=0.6 * HEIGHT**2 / CV)])
    dt = scene.time_step
    times = [tv * HEIGHT**2 / CV for tv in (0.05, 0.2, 0.6)]
    run = run_sampled(scene, [math.ceil(t / dt) for t in times],
                      lambda model, state: state.particle_pore_pressure.numpy()[: model.particle_count].copy())
    zeta = HEIGHT - run.model.particle_x0[:, 1]
    for t, p in zip(run.times, run.samples):
        exact = closed_form(zeta, t)
        l2 = float(np.sqrt(np.mean((p - exact) ** 2))) / P1
        top, base = np.argmin(zeta), np.argmax(zeta)
        print(f"\nT_v = {CV * t / HEIGHT**2:.3f}: top {p[top]:.1f} Pa (exact {exact[top]:.1f}), "
              f"base {p[base]:.1f} Pa (exact {exact[base]:.1f}), L2 {l2:.2e} P1")
        assert l2 < 2e-3
