"""Tools of the stability scoreboard and suite: stepping in memory, the energy ledger's balance over a
march, energies, spacing and peak measures, and the Jacobian of one step (docs/stability.md)."""

from __future__ import annotations

import math

import numpy as np

from warpsph.builder import build
from warpsph.lattice import used_axes
from warpsph.scene import Body, Material, Scene, Simulation
from warpsph.solver import Solver
from warpsph.stages.energy import energy_balance

SOLID = Material("solid", density=2000.0, youngs_modulus=10e6, poisson_ratio=0.3)
"""The elastic solid of the stretched bars, the spinning disc and the free plate."""
DISC_RADIUS, DISC_DX, RIM_SPEED = 1.0, 0.1, 0.1
"""The spinning disc: radius R [m], lattice spacing [m] and rim speed ωR / c."""
DISC_OMEGA = RIM_SPEED * SOLID.p_wave_speed / DISC_RADIUS
"""The spinning disc's angular velocity ω [rad/s]."""


def spinning_disc(**options) -> Scene:
    """The free plane-strain disc of ``SOLID`` in rigid rotation at ``DISC_OMEGA``, unstressed, with the
    Simulation settings ``options``."""
    return Scene(simulation=Simulation(dim=2, dx=DISC_DX, **options), materials={"solid": SOLID},
                 bodies=[Body("disc", "solid", shape="circle", radius=DISC_RADIUS, angular_velocity=DISC_OMEGA)],
                 ).validate()


def march(scene, steps: int, observe=None, every: int = 1, setup=None, device: str | None = None,
          balance: dict | None = None):
    """Build ``scene`` and take ``steps`` steps of its Δt; return (model, state, solver).

    ``setup(model, state)`` may edit the initial state; ``observe(k, model, state)`` is called after
    every ``every``-th step (k = steps taken) and once before the first (k = 0); the run stops early
    when it returns False (a blow-up need not be followed to the end). ``balance``, when given, is
    filled with the energy balance of the steps taken (:func:`~warpsph.stages.energy.energy_balance`;
    the two-set scheme books it).
    """
    model, state = build(scene, device=device)
    if setup is not None:
        setup(model, state)
    scratch = model.state()
    scratch.assign(state)
    solver, dt = Solver(model), scene.time_step
    start = solver.energy.sums(state) if balance is not None else None
    if observe is not None:
        observe(0, model, state)
    for k in range(steps):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        if observe is not None and (k + 1) % every == 0 and observe(k + 1, model, state) is False:
            break
    if balance is not None:
        balance.update(energy_balance(solver.energy.sums(state), start))
    return model, state, solver


def balance_error(balance: dict) -> float:
    """A march's energy balance error over the energy turned over; inf where the run blew up (its sums
    not finite, where the ratio itself would read 0)."""
    finite = all(math.isfinite(v) for v in balance.values())
    return balance["error_ratio"] if finite else math.inf


def cell_share(model) -> np.ndarray:
    """Share of its lattice cell each owned particle stands for: ½ per boundary plane it lies on
    (particles sit on the lattice, faces included, so a face particle holds half a cell)."""
    share = np.ones(model.particle_count)
    planes = model.constraint_planes.numpy().reshape(-1, 3)
    share[model.constraint_particle.numpy()] = 0.5 ** np.sum(planes >= 0, axis=1)
    return share


def energy(model, state) -> float:
    """Kinetic plus elastic strain energy [J per unit area (1D) or length (2D)] of the owned
    particles, each weighted by its volume m/ρ and its :func:`cell_share`; the strain energy
    density of the hypo-elastic stress is s:s/(4G) + (tr σ)²/(18K). A blown-up state gives inf or nan."""
    n = model.particle_count
    materials = list(model.scene.materials.values())
    index = model.particle_material.numpy()[:n]
    shear = np.array([m.shear_modulus for m in materials])[index]
    bulk = np.array([m.bulk_modulus for m in materials])[index]
    with np.errstate(all="ignore"):
        mass = model.particle_mass.numpy()[:n].astype(np.float64) * cell_share(model)
        volume = mass / state.particle_density.numpy()[:n]
        v = state.particle_v.numpy()[:n].astype(np.float64)
        s = state.particle_stress.numpy()[:n].astype(np.float64)
        trace = np.trace(s, axis1=1, axis2=2)
        dev = s - trace[:, None, None] / 3.0 * np.eye(3)
        density = np.einsum("nij,nij->n", dev, dev) / (4.0 * shear) + trace**2 / (18.0 * bulk)
        return float(0.5 * np.sum(mass * np.sum(v * v, axis=1)) + np.sum(volume * density))


def largest_rise(series) -> float:
    """Largest increase of a series over any earlier value of it, relative to its first value."""
    e = np.asarray(series, dtype=float)
    return float(np.max(e - np.minimum.accumulate(e)) / e[0])


def closest_pair(points: np.ndarray) -> float:
    """Smallest distance between two of the (N,3) ``points`` [m] (brute force, chunked)."""
    best = np.inf
    for start in range(0, len(points), 256):
        with np.errstate(all="ignore"):
            d = np.linalg.norm(points[start:start + 256, None, :] - points[None, :, :], axis=2)
        rows = np.arange(d.shape[0])
        d[rows, start + rows] = np.inf
        best = min(best, float(d.min()))
    return best


def step_jacobian(scene, geometry: bool = False) -> np.ndarray:
    """Jacobian of one step of ``scene`` about its initial state, by finite differences: the owned
    particles' velocity components on the used axes, their stress components and, with pore water,
    their pore pressure (stress and pressure in units of ρ c of the scene's first material per 1 m/s,
    so the blocks are of one size). Without ``geometry`` the particles stay where they are, which is
    exact to first order about an unstressed state; with it the state also holds the positions of the
    real particles and of the virtual points (in units of c Δt) and their densities (in units of ρ),
    which a prestressed state's step depends on. Its spectral radius above 1 is a mode that grows by
    that factor per step."""
    model, base = build(scene)
    state, out = model.state(), model.state()
    solver, dt = Solver(model), scene.time_step
    n, nv = model.particle_count, model.virtual_count
    used = used_axes(scene.simulation.dim)
    pairs = [(i, j) for i in range(3) for j in range(i, 3) if (i in used and j in used) or i == j]
    material = next(iter(scene.materials.values()))
    unit = material.density * material.p_wave_speed
    length = material.p_wave_speed * dt
    # (state array, owned count, component (None: a scalar array), scale of one unit)
    fields = [("particle_v", n, k, 1.0) for k in used] + [("particle_stress", n, pair, unit) for pair in pairs]
    if scene.effects.pore_water:
        fields.append(("particle_pore_pressure", n, None, unit))
    if geometry:
        fields += [(name, count, k, length) for name, count in (("particle_q", n), ("virtual_q", nv)) for k in used]
        fields += [("particle_density", n, None, material.density), ("virtual_density", nv, None, material.density)]
    eps = 1e-6 if not geometry else 1e-7

    def pack(s) -> np.ndarray:
        parts = []
        for name, count, comp, scale in fields:
            values = getattr(s, name).numpy()[:count].astype(np.float64) / scale
            parts.append(values if comp is None else values[(slice(None), *np.atleast_1d(comp))])
        return np.concatenate(parts)

    def perturb(name: str, comp, a: int, scale: float) -> None:
        values = getattr(state, name).numpy()
        if comp is None:
            values[a] += eps * scale
        else:
            values[(a, *np.atleast_1d(comp))] += eps * scale
            if isinstance(comp, tuple) and comp[0] != comp[1]:
                values[a, comp[1], comp[0]] += eps * scale
        getattr(state, name).assign(values)

    state.assign(base)
    solver.step(state, out, 0.0, dt)
    rest = pack(out)  # the unperturbed step (at rest and unstressed: the state itself)
    jacobian = np.zeros((rest.size, rest.size))
    columns = ((name, comp, a, scale) for name, count, comp, scale in fields for a in range(count))
    for column, (name, comp, a, scale) in enumerate(columns):
        state.assign(base)
        perturb(name, comp, a, scale)
        solver.step(state, out, 0.0, dt)
        jacobian[:, column] = (pack(out) - rest) / eps
    return jacobian


def force_at_rest(model, state, t: float = 0.0) -> float:
    """Σ_a m_a ‖a_a‖ [N/m or N] over the real particles of one undamped, unfiltered step of ``state``
    with every velocity set to zero: the force their momentum balance leaves unbalanced in that
    configuration and stress, which the unbalanced-force ratio of a damped phase (measured after the
    velocity filter) does not see (docs/stability.md, *What holds the 2D equilibrium floor*)."""
    at_rest, out = model.state(), model.state()
    at_rest.assign(state)
    at_rest.particle_v.zero_()
    dt = model.scene.time_step
    Solver(model).step(at_rest, out, t, dt)
    n = model.particle_count
    dv = out.particle_v.numpy()[:n].astype(np.float64)
    return float(np.sum(model.particle_mass.numpy()[:n] * np.linalg.norm(dv, axis=1)) / dt)
