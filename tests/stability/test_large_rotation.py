"""Large rotation (issue 6, item 4): a spinning elastic disc keeps its stress invariants for 10 turns.

A free plane-strain disc (:func:`stability_tools.spinning_disc`: R = 1 m, Δx = R/10, E = 10 MPa, ν = 0.3,
ρ = 2000 kg/m³, rim speed ωR = 0.1 c, Courant 0.5, 1 257 steps a turn), two-set scheme: the default
settings (α = 0), and the virtual densities following the reals' motion with the velocity filter
(``CONSISTENT``). With artificial viscosity no steady spin is found to 1e-5 (docs/stability.md).

**The start: the disc's discrete steady spin.** A disc started without stress, or in the closed-form
centrifugal state, breathes about its steady state for ever (an elastic vibration, which an exact solver
keeps too), and a disc damped towards rigid rotation settles onto a drift of the real particles'
odd-even velocity, not onto a steady state (docs/stability.md, *Spinning disc*). So the disc starts in
the state one step of the scheme maps onto itself turned by ωΔt (:func:`steady_spin`): rigid rotation,
and the real particles' in-plane stresses and both point sets' densities found by Gauss–Newton from the
closed-form plane-strain stress (σ_r = (3 + ν′)ρω²(R² − r²)/8, σ_θ = ρω²((3 + ν′)R² − (1 + 3ν′)r²)/8,
σ_z = ν(σ_r + σ_θ), ν′ = ν/(1 − ν)) and the material's density, so that after one step every real
particle's velocity is its velocity turned by ωΔt and every virtual point's half-step velocity is the
rigid rotation's ω × x − (Δt/2) ω² x, within 1e-5 ω²R Δt. An objective, torque-free and stable scheme
keeps that state for ever; a stress rate that is not objective, a spurious torque or a growing mode
moves it (without the Jaumann terms no steady spin is found, and the invariants move by 0.15 in a turn).

**Criteria:** over 10 free turns the strain energy and the disc means of tr σ and √J₂ (volume
weighted) stay within 1e-3 of their values at the start; particle by particle, every particle's tr σ and
√J₂ stay within 1e-3 of the largest of each at the start, and the stresses inside R/2 as near the closed
form as at the start; the slow test asks for the means over 30 turns.

Measured (docs/stability.md, *Spinning disc*): inside R/2 the default steady state's stresses lie within
5.4 % of the closed form's largest stress component (rms 1.1 % inside 0.3 R, 2.7 % between 0.3 and 0.5 R)
and its densities within 0.2 %; at the lattice's staircase rim (outside 0.8 R) its stresses move by up to
0.28 ρω²R² and its densities by −21 to +19 % (reals) and −13 to +17 % (virtual points).
"""

import functools

import numpy as np
import pytest
from stability_tools import CONSISTENT, DISC_DX, SOLID, closest_pair, energy, expected_failure, spinning_disc
from stability_tools import DISC_OMEGA as OMEGA
from stability_tools import DISC_RADIUS as RADIUS

from warpsph.builder import build
from warpsph.scene import Scene
from warpsph.solver import Solver

TURNS = 10.0
STEADY_TOLERANCE = 1e-5
"""Largest one-step mismatch of the steady spin, in units of ω²R Δt (real particles' velocities) and
ω²R Δt/2 (virtual points' half-step velocities)."""


def centrifugal_stress(x: np.ndarray) -> np.ndarray:
    """Closed-form plane-strain stress [Pa] of the disc spinning at ``OMEGA``, at the (N,3) points ``x``."""
    rho, nu = SOLID.density, SOLID.poisson_ratio
    nu_plane = nu / (1.0 - nu)
    r2 = x[:, 0] ** 2 + x[:, 1] ** 2
    radial = (3.0 + nu_plane) * rho * OMEGA**2 * (RADIUS**2 - r2) / 8.0
    hoop = rho * OMEGA**2 * ((3.0 + nu_plane) * RADIUS**2 - (1.0 + 3.0 * nu_plane) * r2) / 8.0
    angle = np.arctan2(x[:, 1], x[:, 0])
    c, s = np.cos(angle), np.sin(angle)
    stress = np.zeros((len(x), 3, 3))
    stress[:, 0, 0] = radial * c * c + hoop * s * s
    stress[:, 1, 1] = radial * s * s + hoop * c * c
    stress[:, 0, 1] = stress[:, 1, 0] = (radial - hoop) * s * c
    stress[:, 2, 2] = nu * (radial + hoop)
    return stress


def steady_spin(scene: Scene, iterations: int = 8, regularisation: float = 1e-7):
    """Build ``scene`` (the disc) in its discrete steady spin; return (model, state, solver, unknowns,
    mismatch): the state one step maps onto itself turned by ωΔt.

    Unknowns u: the real particles' in-plane stress components (in units of ρω²R²) and the densities of
    both point sets (relative change), from the closed-form stress and the material's density. Mismatch:
    each real particle's velocity after one step against its velocity turned by ωΔt (units ω²R Δt), each
    virtual point's half-step velocity against ω × x − (Δt/2) ω² x (units ω²R Δt/2). Gauss–Newton with
    a finite-difference Jacobian and a small Tikhonov weight on u (the stress and density change nearest
    to the closed form), until the largest mismatch is below ``STEADY_TOLERANCE``.
    """
    model, base = build(scene)
    solver, dt = Solver(model), scene.time_step
    state, out = model.state(), model.state()
    n, nv = model.particle_count, model.virtual_count
    x, xv = base.particle_q.numpy()[:n].astype(np.float64), base.virtual_q.numpy()[:nv].astype(np.float64)
    spin = np.array([0.0, 0.0, OMEGA])
    turn = np.cos(OMEGA * dt), np.sin(OMEGA * dt)
    turned = np.cross(spin, x) @ np.array([[turn[0], -turn[1], 0.0], [turn[1], turn[0], 0.0], [0.0, 0.0, 1.0]]).T
    half_step = np.cross(spin, xv) - 0.5 * dt * OMEGA**2 * xv * np.array([1.0, 1.0, 0.0])
    closed_form = centrifugal_stress(x)
    unit, acceleration = SOLID.density * OMEGA**2 * RADIUS**2, OMEGA**2 * RADIUS

    def load(u: np.ndarray) -> None:
        state.assign(base)
        stress = state.particle_stress.numpy()
        change = u[:3 * n].reshape(n, 3) * unit
        stress[:n] = closed_form
        stress[:n, 0, 0] += change[:, 0]
        stress[:n, 1, 1] += change[:, 1]
        stress[:n, 0, 1] += change[:, 2]
        stress[:n, 1, 0] += change[:, 2]
        state.particle_stress.assign(stress)
        for name, count, part in (("particle_density", n, u[3 * n:4 * n]), ("virtual_density", nv, u[4 * n:])):
            density = getattr(state, name).numpy()
            density[:count] = SOLID.density * (1.0 + part)
            getattr(state, name).assign(density)

    def mismatch(u: np.ndarray) -> np.ndarray:
        load(u)
        solver.step(state, out, 0.0, dt)
        real = (out.particle_v.numpy()[:n] - turned)[:, :2] / (acceleration * dt)
        virtual = (solver.virtual_v.numpy()[:nv] - half_step)[:, :2] / (0.5 * acceleration * dt)
        return np.concatenate([real.ravel(), virtual.ravel()])

    u = np.zeros(4 * n + nv)
    r = mismatch(u)
    eps = 1e-6
    for _ in range(iterations):
        if np.abs(r).max() < STEADY_TOLERANCE:
            break
        jacobian = np.empty((r.size, u.size))
        for k in range(u.size):
            probe = u.copy()
            probe[k] += eps
            jacobian[:, k] = (mismatch(probe) - r) / eps
        weight = np.sqrt(regularisation)
        system = np.vstack([jacobian, weight * np.eye(u.size)])
        u = u + np.linalg.lstsq(system, np.concatenate([-r, -weight * u]), rcond=None)[0]
        r = mismatch(u)
    load(u)
    return model, state, solver, u, np.abs(r).max()


def particle_invariants(model, state) -> np.ndarray:
    """(N, 2) tr σ and √J₂ [Pa] of every real particle."""
    s = state.particle_stress.numpy()[:model.particle_count].astype(np.float64)
    trace = np.trace(s, axis1=1, axis2=2)
    dev = s - trace[:, None, None] / 3.0 * np.eye(3)
    return np.stack([trace, np.sqrt(0.5 * np.einsum("nij,nij->n", dev, dev))], axis=1)


def invariants(model, state) -> np.ndarray:
    """Strain energy [J/m] and the disc means (volume weighted) of tr σ and √J₂ [Pa]."""
    n = model.particle_count
    volume = model.particle_mass.numpy()[:n] / state.particle_density.numpy()[:n]
    v = state.particle_v.numpy()[:n].astype(np.float64)
    kinetic = 0.5 * np.sum(model.particle_mass.numpy()[:n] * np.sum(v * v, axis=1))
    means = np.average(particle_invariants(model, state), axis=0, weights=volume)
    return np.array([energy(model, state) - kinetic, *means])


@functools.cache
def settled(options: tuple):
    """(scene, model, steady state, solver, unknowns, mismatch) of the disc with the Simulation settings
    ``options`` ((name, value) pairs), by :func:`steady_spin`."""
    scene = spinning_disc(**dict(options))
    return scene, *steady_spin(scene)


def free_turns(options: tuple, turns: float):
    """Run the disc of :func:`settled` free from its steady spin for ``turns`` (the steady state itself is
    kept); return per quarter turn (turns, invariants relative to the start − 1), and the model and state
    at the end."""
    scene, model, steady, solver, _, mismatch = settled(options)
    assert mismatch < STEADY_TOLERANCE, f"no steady spin found: one-step mismatch {mismatch:.1e}"
    dt = scene.time_step
    state, scratch = model.state(), model.state()
    state.assign(steady)
    scratch.assign(steady)
    period = 2.0 * np.pi / OMEGA
    every = int(round(period / (4.0 * dt)))
    start, rows = invariants(model, state), []
    for k in range(int(np.ceil(turns * period / dt))):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        if (k + 1) % every == 0:
            now = invariants(model, state)
            rows.append(((k + 1) * dt / period, *(now / start - 1.0)))
            if not np.all(np.isfinite(now)):
                break
    return np.array(rows), model, state


def closed_form_deviation(model, state) -> float:
    """Largest deviation of the real particles' stresses inside R/2 from the closed form at their
    positions, over the closed form's largest stress component."""
    n = model.particle_count
    x = state.particle_q.numpy()[:n].astype(np.float64)
    inside = np.linalg.norm(x[:, :2], axis=1) < 0.5 * RADIUS
    closed_form = centrifugal_stress(x)
    return float(np.abs(state.particle_stress.numpy()[:n] - closed_form)[inside].max() / np.abs(closed_form).max())


def test_steady_spin_is_the_centrifugal_state():
    """The discrete steady spin is found (every mismatch below ``STEADY_TOLERANCE``) and is the closed
    form's centrifugal state away from the lattice's staircase rim: inside R/2 its stresses lie within 6 %
    of the closed form's largest stress component, its densities within 1 %."""
    _, model, state, _, u, mismatch = settled(())
    n = model.particle_count
    inside = np.linalg.norm(state.particle_q.numpy()[:n, :2], axis=1) < 0.5 * RADIUS
    stress_error = closed_form_deviation(model, state)
    density = u[3 * n:4 * n]
    print(f"\nsteady spin: mismatch {mismatch:.1e}; inside R/2 stress within {stress_error:.3f} of the peak, "
          f"density [{density[inside].min():+.4f}, {density[inside].max():+.4f}]; everywhere density "
          f"[{density.min():+.3f}, {density.max():+.3f}] (reals), [{u[4 * n:].min():+.3f}, {u[4 * n:].max():+.3f}] "
          f"(virtual points), stress change up to {np.abs(u[:3 * n]).max():.3f} ρω²R²")
    assert mismatch < STEADY_TOLERANCE
    assert stress_error < 0.06
    assert np.abs(density[inside]).max() < 0.01


@functools.cache
def ten_free_turns(options: tuple):
    """:func:`free_turns` for ``TURNS``: (rows; the stresses' deviation from the closed form inside R/2 at the
    start and at the end; the largest change of each particle's tr σ and √J₂ over the largest of each at
    the start; the closest pair of particles at the end over Δx)."""
    rows, model, state = free_turns(options, TURNS)
    steady = settled(options)[2]
    before, after = particle_invariants(model, steady), particle_invariants(model, state)
    change = np.abs(after - before).max(axis=0) / np.abs(before).max(axis=0)
    pair = closest_pair(state.particle_q.numpy()[:model.particle_count]) / DISC_DX
    return rows, closed_form_deviation(model, steady), closed_form_deviation(model, state), change, pair


@pytest.mark.parametrize("options", [(), CONSISTENT], ids=["default", "consistent"])
def test_spinning_disc_keeps_its_stress_invariants_for_ten_turns(options):
    """Issue item 4: from its discrete steady spin the disc turns 10 times freely; its strain energy and
    mean tr σ and √J₂ stay within 1e-3 of their start (no spurious strain energy), and no pair of particles
    closes in (closest pair above half the spacing)."""
    rows, _, _, _, pair = ten_free_turns(options)
    change = np.abs(rows[:, 1:]).max(axis=0)
    print(f"\ndisc {dict(options) or 'default'}, {rows[-1, 0]:.2f} free turns from the steady spin: largest "
          f"relative change of the strain energy {change[0]:.1e}, of mean tr σ {change[1]:.1e}, of mean √J₂ "
          f"{change[2]:.1e}; closest pair {pair:.4f} Δx")
    assert rows[-1, 0] > TURNS - 0.05
    assert np.all(change <= 1e-3)
    assert pair > 0.5


@pytest.mark.parametrize("options", [pytest.param((), marks=expected_failure(
    "the disc means hold, but the m = 2 mode growing out of the steady spin changes single particles' √J₂ by "
    "4.1e-2 and tr σ by 1.1e-2 of their peak, and moves the stresses inside R/2 from 5.4 % to 10.0 % of the "
    "closed form's peak off it (measured, docs/stability.md)")), CONSISTENT], ids=["default", "consistent"])
def test_spinning_disc_keeps_every_particles_stress_for_ten_turns(options):
    """Items 4 and 1 particle by particle, on the same run (about 630 transits of R at the P-wave speed):
    every particle's tr σ and √J₂ stay within 1e-3 of the largest of each at the start, and inside R/2 the
    stresses stay within 6 % of the closed form's largest stress component, as at the start (5.4 %)."""
    rows, start, end, change, _ = ten_free_turns(options)
    print(f"\ndisc {dict(options) or 'default'}, {rows[-1, 0]:.2f} free turns: largest change of a particle's "
          f"tr σ {change[0]:.1e}, of its √J₂ {change[1]:.1e}; inside R/2 the stress within {end:.4f} of the "
          f"closed form's peak ({start:.4f} at the start)")
    assert rows[-1, 0] > TURNS - 0.05
    assert np.all(change <= 1e-3)
    assert end < 0.06


LONG_TURNS = 30.0
"""Turns of the slow run: the steady spin carries a slowly growing mode (docs/stability.md)."""


@pytest.mark.slow
@pytest.mark.parametrize("options", [
    pytest.param((), marks=expected_failure(
        "a mode of the whole disc, largest at the rim, grows out of the steady spin (twin runs: the stress "
        "difference e-folds in about 0.4 turn): 1.9e-4 at 10 turns, blow-up between 11 and 12 turns (measured, "
        "docs/stability.md)")),
    pytest.param(CONSISTENT, marks=expected_failure(
        "the same mode, slower: 1.2e-4 at 20 turns, 2.1e-4 at 24, 3.6e-2 at 28 (measured, docs/stability.md)")),
    (("velocity_filter", 0.05), ("virtual_density", "real_motion")),
], ids=["default", "consistent", "consistent-0.05"])
def test_spinning_disc_keeps_its_stress_invariants_for_thirty_turns(options):
    """As the 10-turn test, for 30 turns: the steady spin must not merely outlast the issue's 10 turns. The
    mode that grows out of it is held by the velocity filter at β = 0.05 (``consistent-0.05``), not at 0.02."""
    rows, _, _ = free_turns(options, LONG_TURNS)
    change = np.abs(rows[:, 1:]).max(axis=1)
    beyond = rows[change > 1e-3, 0]
    print(f"\ndisc {dict(options) or 'default'}, {LONG_TURNS:.0f} free turns: largest change "
          f"{change.max():.1e}, first beyond 1e-3 after {beyond[0] if beyond.size else np.inf:.2f} turns")
    assert rows[-1, 0] > LONG_TURNS - 0.05
    assert np.all(change <= 1e-3)
