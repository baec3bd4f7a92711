"""The scoreboard's elastic cases: patch tests of the control, free surfaces and corners, stretching,
rotation and a prestressed block (docs/stability.md, *Scoreboard*)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from warpsph.scene import Body, Boundary, Material, Scene, Simulation
from warpsph.stability.board import Measure, case, configure, without_stabilisation
from warpsph.stability.tools import (
    DISC_OMEGA, DISC_RADIUS, SOLID, balance_error, closest_pair, energy, largest_rise, march, spinning_disc,
    step_jacobian,
)
from warpsph.validation.report import shipped_scene

PATCH_STEPS = 1
ROUND_OFF = 1e-10
"""A control that is zero for a field may still change it by round-off, relative to the field's scale."""
NOISE = 1e-3
"""Standard deviation of the free plate's seeded velocity per component [m/s]."""
SOIL = Material("soil", density=1000.0, youngs_modulus=1.0e8, poisson_ratio=0.25)
"""The free-surface tests' soil: the prestressed block's."""


def _plate(size: tuple[float, float], options, **settings) -> Scene:
    """A free plane-strain plate of ``SOLID`` (no planes, no gravity), Δx = 0.1 m."""
    scene = Scene(simulation=Simulation(dim=2, dx=0.1, **settings), materials={"solid": SOLID},
                  bodies=[Body("plate", "solid", min=(0, 0, 0), max=(*size, 0))])  # fmt: skip
    return configure(scene, options)


def _without_control(scene: Scene) -> Scene:
    return without_stabilisation(dataclasses.replace(scene, simulation=dataclasses.replace(scene.simulation)))


def _patch(options, field) -> Measure:
    """Three steps of a free plate in the motion ``field(x) -> v``, with the options and with every
    control off: the largest change the control makes to a particle's velocity (over the largest speed)
    or stress (over ρ c times it)."""
    scene = _plate((1.0, 0.6), options)
    speed = 1e-3 * SOLID.p_wave_speed

    def start(model, state):
        v = state.particle_v.numpy()
        v[: model.particle_count, :2] = field(model.particle_x0[:, :2] - 0.5 * np.array([1.0, 0.6])) * speed
        state.particle_v.assign(v)

    balance = {}
    runs = [march(s, PATCH_STEPS, setup=start, balance=b) for s, b in ((scene, balance), (_without_control(scene), {}))]
    (model, a, _), (_, b, _) = runs
    n = model.particle_count
    vmax = np.abs(b.particle_v.numpy()[:n]).max()
    dv = np.abs(a.particle_v.numpy()[:n] - b.particle_v.numpy()[:n]).max() / vmax
    ds = np.abs(a.particle_stress.numpy()[:n] - b.particle_stress.numpy()[:n]).max() / (
        SOLID.density * SOLID.p_wave_speed * vmax)
    return Measure("largest change by the control", max(dv, ds), ROUND_OFF, energy_error=balance_error(balance),
                   detail=f"velocity {dv:.3g}, stress {ds:.3g}; {n} particles, {PATCH_STEPS} steps")


@case("patch_affine", "affine motion of a free plate: the control is zero")
def patch_affine(options) -> Measure:
    """A general affine velocity field (stretch, shear and spin; surfaces and corners included)."""
    gradient = np.array([[1.0, 0.7], [-0.3, -0.6]])
    return _patch(options, lambda x: np.array([0.2, -0.1]) + x @ gradient.T)


@case("patch_rotation", "rigid rotation of a free plate: the control is zero")
def patch_rotation(options) -> Measure:
    return _patch(options, lambda x: np.stack([-x[:, 1], x[:, 0]], axis=1))


def seeded_plate_energies(scene: Scene, steps: int, balance: dict | None = None) -> np.ndarray:
    """The total energy (kinetic + strain) of a body seeded with ``NOISE`` at rest, every 100 of
    ``steps`` steps; the march stops once it has grown a hundredfold (``balance`` as :func:`march`)."""
    energies = []

    def seed(model, state):
        n = model.particle_count
        v = state.particle_v.numpy()
        v[:n, :2] = NOISE * np.random.default_rng(0).standard_normal((n, 2))
        state.particle_v.assign(v)

    def observe(k, model, state):
        energies.append(energy(model, state))
        return bool(energies[-1] < 100.0 * energies[0])

    march(scene, steps, observe, every=100, setup=seed, balance=balance)
    return np.array(energies)


def free_plate_scene(options=None, **settings) -> Scene:
    """The free plate 2 m × 0.4 m of docs/stability.md, *Free plate*."""
    return _plate((2.0, 0.4), options or {}, **settings)


@case("free_plate", "free plate 2 m × 0.4 m, seeded noise, 3 000 steps")
def free_plate(options) -> Measure:
    """Total energy (kinetic + strain) never rises more than 0.1 %: nothing drives the plate."""
    balance = {}
    energies = seeded_plate_energies(free_plate_scene(options), 3000, balance)
    return Measure("largest rise of the total energy", largest_rise(energies), 1e-3,
                   energy_error=balance_error(balance), detail=f"{100 * (len(energies) - 1)} steps, {energies[-1] / energies[0]:.3g} of the start left")


@case("cantilever", "cantilever released under gravity, 10 periods, Δx = 0.1 m")
def cantilever(options) -> Measure:
    """The shipped cantilever at the defaults (its stabilisation keys reset), at Δx = 0.1 m for ten of
    its first periods (0.152 s by Euler–Bernoulli): the energy balance closes and the run stays finite."""
    scene = without_stabilisation(shipped_scene("cantilever"))
    scene.simulation.dx, scene.probes = 0.1, []
    scene = configure(scene, options)
    steps = math.ceil(10 * 0.152 / scene.time_step)
    tip = []

    def observe(k, model, state):
        tip.append(float(np.abs(state.particle_v.numpy()[: model.particle_count]).max()))
        return math.isfinite(tip[-1]) and tip[-1] < scene.max_p_wave_speed

    balance = {}
    march(scene, steps, observe, every=100, balance=balance)
    ran = 100 * (len(tip) - 1)
    error = balance_error(balance) if ran >= steps - 100 else math.inf
    return Measure("energy balance error", error, 0.01, energy_error=error,
                   detail=f"{ran} of {steps} steps; largest speed {max(tip):.3g} m/s")


@case("free_bar", "free-sided bar stretched 1 % in 20 transits")
def free_bar(options) -> Measure:
    """A plane-strain bar 2 m × 0.4 m (Δx = 0.05 m) between clamped ends moving apart, started in the
    matching homogeneous motion with 1 % velocity noise: the stress on its central half within 1 % of
    the closed form σ_xx = E ln(1 + ε)/(1 − ν²), σ_yy = 0 after the first transit."""
    length, width, dx, transits = 2.0, 0.4, 0.05, 20
    duration = transits * length / SOLID.p_wave_speed
    rate = 0.01 / duration
    speed = rate * length / 2
    nu = SOLID.poisson_ratio
    ends = [Boundary("left", "velocity", "x", -length / 2, "min", velocity=(-speed, 0, 0)),
            Boundary("right", "velocity", "x", length / 2, "max", velocity=(speed, 0, 0))]  # fmt: skip
    scene = configure(Scene(simulation=Simulation(dim=2, dx=dx), materials={"solid": SOLID},
                            bodies=[Body("bar", "solid", min=(-length / 2, 0, 0), max=(length / 2, width, 0))],
                            boundaries=ends), options)  # fmt: skip
    modulus = SOLID.youngs_modulus / (1 - nu**2)

    def start(model, state):
        n, x = model.particle_count, model.particle_x0
        v = state.particle_v.numpy()
        v[:n, 0] = rate * x[:, 0]
        v[:n, 1] = -nu / (1 - nu) * rate * (x[:, 1] - width / 2)
        v[:n, :2] += 0.01 * speed * np.random.default_rng(0).standard_normal((n, 2))
        state.particle_v.assign(v)

    rows = []

    def observe(k, model, state):
        n, x0 = model.particle_count, model.particle_x0
        stress = state.particle_stress.numpy()[:n]
        e = math.log1p(rate * k * scene.time_step)
        inner = np.abs(x0[:, 0]) <= length / 4
        noise = 0.0 if e <= 0 else max(np.abs(stress[inner, 0, 0] - modulus * e).max(),
                                       np.abs(stress[inner, 1, 1]).max()) / (modulus * e)  # fmt: skip
        fastest = np.abs(state.particle_v.numpy()[:n]).max() / speed
        rows.append((noise, closest_pair(state.particle_q.numpy()[:n]) / dx, fastest))
        return bool(fastest < 100.0)

    steps = math.ceil(duration / scene.time_step)
    balance = {}
    march(scene, steps, observe, every=round(steps / transits), setup=start, balance=balance)
    rows = np.array(rows)
    noise = float(np.max(rows[2:, 0])) if len(rows) > transits else math.inf
    return Measure("stress noise after the first transit", noise, 0.01, energy_error=balance_error(balance),
                   detail=f"closest pair {rows[:, 1].min():.3f} Δx, largest speed {rows[:, 2].max():.3g} v₀")


@case("spinning_disc", "free disc spinning at ωR = 0.1 c, 2 turns")
def spinning_disc_case(options) -> Measure:
    """The free plane-strain disc (R = 1 m, Δx = 0.1 m), unstressed at the start: its total energy never
    rises more than 0.1 %."""
    scene = configure(spinning_disc(), options)
    period = 2 * math.pi / DISC_OMEGA
    steps = math.ceil(2 * period / scene.time_step)
    rows = []

    def observe(k, model, state):
        n = model.particle_count
        rows.append((energy(model, state), closest_pair(state.particle_q.numpy()[:n]) / scene.simulation.dx))
        fastest = np.linalg.norm(state.particle_v.numpy()[:n], axis=1).max() / (DISC_OMEGA * DISC_RADIUS)
        return bool(fastest < 100.0)

    balance = {}
    march(scene, steps, observe, every=round(steps / 8), balance=balance)
    rows = np.array(rows)
    rise = largest_rise(rows[:, 0]) if len(rows) == 9 and np.all(np.isfinite(rows)) else math.inf
    return Measure("largest rise of the total energy", rise, 1e-3, energy_error=balance_error(balance),
                   detail=f"{(len(rows) - 1) / 4:.2f} turns; closest pair {np.nanmin(rows[:, 1]):.3f} Δx")


@case("block_own_weight", "block under its own weight: one step's spectral radius")
def block_own_weight(options) -> Measure:
    """A 1 m × 1 m block (Δx = 0.1 m) on a fixed base, free top and sides, in its geostatic state: the
    spectral radius of one step's Jacobian, positions and densities of both point sets included, at most
    1 + 3e-5 (a growth of 0.2 /s at its Δt)."""
    scene = configure(Scene(simulation=Simulation(dim=2, dx=0.1, gravity=(0, -9.81, 0)), materials={"soil": SOIL},
                            bodies=[Body("block", "soil", min=(0, 0, 0), max=(1.0, 1.0, 0), geostatic=True)],
                            boundaries=[Boundary("base", "fixed", "y", 0.0, "min")]), options)  # fmt: skip
    eigenvalues = np.linalg.eigvals(step_jacobian(scene, geometry=True))
    top = eigenvalues[np.argmax(np.abs(eigenvalues))]
    return Measure("spectral radius − 1", float(np.abs(top) - 1.0), 3e-5,
                   detail=f"growth {np.log(np.abs(top)) / scene.time_step:.3g} /s")
