"""The plasticity effect through the whole two-set solver (Perzyna, von Mises, no hardening).

Units SI, tension positive. Closed forms:

- Relaxation at rest: a confined column prestressed above yield with a uniform stress stays at rest
  (div σ′ = 0), so every particle is a frozen material point: F = σ_eq − σ_Y relaxes as
  F₀′ exp(−3Gγt/F₀) (N = 1; tests/test_plasticity.py derives the rate 3G).
- Confined compression (1D column along y, ε_xx = ε_zz = 0, top driven down slowly): von Mises
  flow is deviatoric, so the mean stress stays elastic, tr σ′/3 = −K ln(L₀/L) (Jaumann rate,
  d_yy = −v/L), and after yield σ_eq = |σ_yy − σ_xx| = σ_Y plus the Perzyna overstress
  F = F₀ (2/3)|ε̇|/γ (dε̄/dt = γF/F₀ = (2/3)|ε̇| in steady flow), here 8e-4 σ_Y.
"""

import dataclasses
import math

import numpy as np
import pytest

from warpsph.builder import build
from warpsph.fields import mean_stress, von_mises
from warpsph.io import load_results
from warpsph.io.checkpoint import load_checkpoint
from warpsph.launching import record_launches
from warpsph.runner import Run
from warpsph.scene import Body, Boundary, Effects, Material, Scene, Simulation, TimeFunction
from warpsph.scene_toml import load_scene
from warpsph.solver import Solver

E, NU, COHESION, DENSITY = 10e6, 0.3, 10e3, 2000.0
SIGMA_Y = math.sqrt(3.0) * COHESION
SHEAR = E / (2.0 * (1.0 + NU))
BULK = E / (3.0 * (1.0 - 2.0 * NU))


def soil(**plastic) -> Material:
    return Material(name="soil", density=DENSITY, youngs_modulus=E, poisson_ratio=NU, model="viscoplastic",
                    cohesion=COHESION, **plastic)  # fmt: skip


def column(material: Material, top: Boundary, dx: float, stress=(0.0,) * 6) -> Scene:
    """A 1D column 0 ≤ y ≤ 1 m on a fixed base."""
    return Scene(
        name="plastic_column",
        simulation=Simulation(dim=1, dx=dx, end_time=1.0),
        effects=Effects(plasticity=True),
        materials={"soil": material},
        bodies=[Body(name="column", material="soil", min=(0.0, 0.0, 0.0), max=(0.0, 1.0, 0.0), stress=stress)],
        boundaries=[Boundary(name="base", kind="fixed", axis="y", position=0.0, side="min"), top],
    ).validate()


def advance(scene: Scene, steps: int, every: int = 1):
    """Run ``steps`` steps; yield (t, model, state) every ``every`` steps."""
    model, state = build(scene)
    scratch = model.state()
    scratch.assign(state)
    solver, dt = Solver(model), scene.time_step
    for k in range(steps):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        if (k + 1) % every == 0:
            yield (k + 1) * dt, model, state


@pytest.mark.parametrize("rate_dt", [0.025, 3.0], ids=["mild", "stiff (sub-stepped)"])
def test_relaxation_at_rest_follows_the_exponential(rate_dt):
    """λ_vp Δt = 0.025: the rate to 1 %; λ_vp Δt = 3 (three RK4 sub-steps a step): the overstress within
    1 % of its initial value at every step (plasticity.py, RELAXATION_STEP)."""
    stress = (-10e3, -30e3, -10e3, 0.0, 0.0, 0.0)  # σ_eq = 20 kPa > σ_Y = 17.3 kPa
    top = Boundary(name="top", kind="fixed", axis="y", position=1.0, side="max")
    reference = 10e3
    dt = column(soil(), top, dx=0.1).time_step
    rate = rate_dt / dt
    fluidity = rate * reference / (3.0 * SHEAR)
    scene = column(soil(fluidity=fluidity, reference_stress=reference), top, dx=0.1, stress=stress)
    steps, every = (100, 10) if rate_dt < 1.0 else (4, 1)
    times, over, eps, speed = [0.0], [20e3 - SIGMA_Y], [0.0], 0.0
    for t, model, state in advance(scene, steps, every):
        n = model.particle_count
        sigma_eq = von_mises(state.particle_stress.numpy()[:n])
        assert np.ptp(sigma_eq) < 1e-9 * SIGMA_Y  # uniform: every particle is the same material point
        times.append(t)
        over.append(sigma_eq.mean() - SIGMA_Y)
        eps.append(state.particle_plastic_strain.numpy()[:n].mean())
        speed = max(speed, np.abs(state.particle_v.numpy()[:n]).max())
    exact = over[0] * np.exp(-rate * np.array(times))
    error = np.abs(np.array(over) - exact).max() / over[0]
    measured = -np.polyfit(times, np.log(over), 1)[0]
    print(f"\nλΔt = {rate_dt}: rate {measured:.3f} /s, exact {rate:.3f} /s ({100 * (measured / rate - 1):+.4f} %), "
          f"largest error {100 * error:.3f} % of the initial overstress, after {rate * times[-1]:.2f} e-folds")
    if rate_dt < 1.0:
        assert measured == pytest.approx(rate, rel=0.01)
    assert error < 0.01
    # σ_eq + 3Gε̄ is conserved at a frozen point; the column does not move
    assert np.allclose(np.array(over) + 3.0 * SHEAR * np.array(eps), over[0], rtol=1e-6)
    assert speed < 1e-9


@pytest.mark.parametrize("yield_function", ["drucker_prager", "mohr_coulomb"])
def test_frictional_surfaces_relax_in_the_solver(yield_function):
    """φ = 30°, ψ = 10° at rest above yield: the column stays at rest and relaxes onto F = 0 (checked
    on the host: Drucker–Prager √J₂ + αI₁ = k; Mohr–Coulomb in triaxial compression, where the rounding
    lies inside the sharp cone by up to 4.5 % of √J₂ at the triaxial-compression corner)."""
    phi = math.radians(30.0)
    stress = (-10e3, -80e3, -10e3, 0.0, 0.0, 0.0)  # triaxial compression, outside both cones
    top = Boundary(name="top", kind="fixed", axis="y", position=1.0, side="max")
    material = soil(yield_function=yield_function, friction_angle=30.0, dilatancy_angle=10.0, fluidity=10.0)
    scene = column(material, top, dx=0.1, stress=stress)
    *_, (t, model, state) = advance(scene, 40, every=40)
    n = model.particle_count
    sigma = state.particle_stress.numpy()[:n]
    assert np.abs(state.particle_v.numpy()[:n]).max() < 1e-9
    assert state.particle_plastic_strain.numpy()[:n].min() > 0.0
    i1 = np.trace(sigma, axis1=1, axis2=2)
    j2 = von_mises(sigma) ** 2 / 3.0
    if yield_function == "drucker_prager":
        root = math.sqrt(9.0 + 12.0 * math.tan(phi) ** 2)
        f = np.sqrt(j2) + math.tan(phi) / root * i1 - 3.0 * COHESION / root
        assert np.abs(f).max() < 0.01 * COHESION
    else:
        principal = np.linalg.eigvalsh(sigma)  # ascending: σ₃ (most compressive) first
        sharp = (principal[:, 2] - principal[:, 0]) / 2 + (principal[:, 2] + principal[:, 0]) / 2 * math.sin(phi)
        f = sharp - COHESION * math.cos(phi)
        print(f"\nMohr–Coulomb: sharp F after relaxation {f.min():.0f} to {f.max():.0f} Pa")
        assert np.all(f < 0.01 * COHESION)  # at or inside the sharp cone: the rounded surface lies inside it
        assert np.all(f > -0.05 * np.sqrt(j2))  # by no more than the rounding (4.5 % of √J₂ at 30°)


def test_softening_stops_at_the_residual_cohesion():
    """With H < 0 (here √3H = −0.9·3G, steep but 3G + √3H > 0) the relaxing column softens until
    c(ε̄) = max(c + Hε̄, c_r) reaches c_r and then relaxes onto σ_eq = √3 c_r."""
    stress = (-10e3, -30e3, -10e3, 0.0, 0.0, 0.0)
    top = Boundary(name="top", kind="fixed", axis="y", position=1.0, side="max")
    residual = 0.5 * COHESION
    material = soil(fluidity=100.0, reference_stress=10e3, hardening_modulus=-6e6, residual_cohesion=residual)
    *_, (t, model, state) = advance(column(material, top, dx=0.1, stress=stress), 60, every=60)
    n = model.particle_count
    sigma_eq = von_mises(state.particle_stress.numpy()[:n])
    eps = state.particle_plastic_strain.numpy()[:n]
    assert np.allclose(sigma_eq, math.sqrt(3.0) * residual, rtol=1e-3)
    assert np.all(eps > (COHESION - residual) / 6e6)  # beyond the strain where the floor is reached


def test_confined_compression_plateaus_at_the_yield_stress():
    speed, ramp, end = 0.012, 0.05, 0.4  # top at 0.012 m/s after a 0.05 s ramp: |ε̇| = 0.012 /s
    fluidity = 10.0
    top = Boundary(name="top", kind="velocity", axis="y", position=1.0, side="max", velocity=(0.0, -speed, 0.0),
                   time_function=TimeFunction(kind="ramp", duration=ramp))  # fmt: skip
    scene = column(soil(fluidity=fluidity, reference_stress=SIGMA_Y), top, dx=0.05)
    steps = int(end / scene.time_step)
    worst_plateau = worst_mean = 0.0
    yielded_at = None
    for t, model, state in advance(scene, steps, every=20):
        n = model.particle_count
        sigma = state.particle_stress.numpy()[:n]
        q = state.particle_q.numpy()[:n, 1]
        length = q.max() - q.min()
        strain = math.log((model.particle_x0[:, 1].max() - model.particle_x0[:, 1].min()) / length)
        eps = state.particle_plastic_strain.numpy()[:n]
        if yielded_at is None and eps.max() > 0.0:
            yielded_at = strain
        if t > 0.1:  # after the ramp's wave has crossed the column a few times (H/c_p = 0.012 s)
            worst_mean = max(worst_mean, np.abs(mean_stress(sigma) / (-BULK * strain) - 1.0).max())
        if t > 0.3:
            worst_plateau = max(worst_plateau, np.abs(von_mises(sigma) / SIGMA_Y - 1.0).max())
            assert np.all(sigma[:, 1, 1] < sigma[:, 0, 0])  # compression: σ_yy − σ_xx = −σ_Y
    print(f"\nyield at strain {yielded_at:.3e} (elastic {SIGMA_Y / (2 * SHEAR):.3e}); plateau |σ_eq/σ_Y − 1| ≤ "
          f"{worst_plateau:.2e} (Perzyna overstress {2 / 3 * speed / fluidity:.1e}); mean stress ≤ {worst_mean:.2e}")
    assert yielded_at == pytest.approx(SIGMA_Y / (2.0 * SHEAR), rel=0.05)
    assert worst_plateau < 0.01
    assert worst_mean < 0.01
    assert eps.min() > 0.0


def test_run_writes_and_checkpoints_plastic_strain(tmp_path):
    stress = (-10e3, -30e3, -10e3, 0.0, 0.0, 0.0)
    top = Boundary(name="top", kind="fixed", axis="y", position=1.0, side="max")
    scene = column(soil(fluidity=1.0, reference_stress=10e3), top, dx=0.1, stress=stress)
    scene.output.usd = False
    scene.output.frame_interval = 5 * scene.time_step
    run = Run(scene, tmp_path, end_time=10.5 * scene.time_step)
    run.run()
    results = load_results(tmp_path / "results.h5")
    last = results.frame(len(results) - 1)["plastic_strain"]
    assert last.shape == (run.model.particle_count,) and np.all(last > 0.0)
    saved = load_checkpoint(tmp_path / "checkpoint.h5").arrays["particle_plastic_strain"]
    assert np.array_equal(saved, run.state.particle_plastic_strain.numpy())


def test_resume_continues_the_plastic_strain(tmp_path):
    """A run stopped and resumed equals the uninterrupted one bit for bit, ε̄ included."""
    stress = (-10e3, -30e3, -10e3, 0.0, 0.0, 0.0)
    top = Boundary(name="top", kind="velocity", axis="y", position=1.0, side="max", velocity=(0.0, -0.01, 0.0))
    scene = column(soil(fluidity=1.0, reference_stress=10e3), top, dx=0.1, stress=stress)
    scene.output.usd = False
    dt = scene.time_step
    scene.output.frame_interval = 5 * dt
    whole = Run(scene, tmp_path / "whole", end_time=20.5 * dt)
    whole.run()
    Run(scene, tmp_path / "split", end_time=10.5 * dt).run()
    second = Run(scene, tmp_path / "split", end_time=20.5 * dt, resume=True)
    second.run()
    for name, arr in whole.state.arrays().items():
        assert np.array_equal(arr.numpy(), second.state.arrays()[name].numpy()), name


def test_works_with_pore_water(scenes_dir):
    """Terzaghi's column with a weak viscoplastic skeleton: the effective stress relaxes to the surface
    (under the drained top the load strains the skeleton fast, so there the overstress is larger)."""
    scene = load_scene(scenes_dir / "terzaghi.toml")
    scene.effects = dataclasses.replace(scene.effects, plasticity=True)
    material = scene.materials["soil"]
    material.model, material.cohesion, material.fluidity, material.reference_stress = "viscoplastic", 100.0, 1.0, 1e4
    scene.validate()  # σ′_eq = 341 Pa at t = 0, above σ_Y = 173 Pa
    with record_launches() as launched:
        *_, (t, model, state) = advance(scene, 30, every=30)
    assert any("plastic" in k for k in launched) and any("pressure" in k or "projection" in k for k in launched)
    n = model.particle_count
    sigma_eq = von_mises(state.particle_stress.numpy()[:n])
    assert np.isfinite(state.particle_pore_pressure.numpy()).all()
    deep = state.particle_q.numpy()[:n, 1] < 9.0  # below the top metre, which the load strains fast
    assert sigma_eq[deep].max() < 1.01 * math.sqrt(3.0) * 100.0
    assert sigma_eq.max() < 1.25 * math.sqrt(3.0) * 100.0  # Perzyna overstress where it is strained fast
    assert state.particle_plastic_strain.numpy()[:n].min() > 0.0
