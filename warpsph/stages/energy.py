"""Energy balance: each real particle's ledger of the work done on it and the energy it lost.

The step's kernels add to a particle's row as they change its state; the kinetic and strain energies
are states, read with the ledger's sums at output times, so no step waits on the host. What each
column holds and what the balance measures: docs/method.md, *Energy balance*.
"""


import functools

import numpy as np
import warp as wp

from warpsph.launching import launch
from warpsph.model import Model, State
from warpsph.physics.elastic import strain_energy_density
from warpsph.sph.spec import Spec

PLASTIC, PORE_WATER, VISCOUS, STABILISATION, GRAVITY, BOUNDARIES, RIGID, DAMPING = range(8)
"""Columns of the ledger: dissipations (plastic, viscous, stabilisation, damping) are counted as
energy lost, works (gravity, boundaries, rigid regions, pore water) as energy given."""
CHANNELS = 8
DISSIPATIONS = {"plastic_dissipation": PLASTIC, "viscous_dissipation": VISCOUS,
                "stabilisation_dissipation": STABILISATION, "damping_dissipation": DAMPING}  # fmt: skip
WORKS = {"gravity_work": GRAVITY, "boundary_work": BOUNDARIES, "rigid_load_work": RIGID,
         "pore_water_work": PORE_WATER}  # fmt: skip
STABILISATION_WARNING = 0.1
"""Stabilisation energy above this fraction of the strain energy's change is reported."""
BALANCE_WARNING = 0.01
"""A balance that misses by more than this fraction of the energy turned over is reported."""


@functools.cache
def _boundary_kernel(spec: Spec):
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    half = real(0.5)

    @wp.kernel(enable_backward=False, module="unique")
    def boundary_work(
        particle: wp.array(dtype=wp.int32),
        planes_of: wp.array(dtype=wp.vec3i),
        plane_axis: wp.array(dtype=wp.int32),
        plane_sign: wp.array(dtype=real),
        spacing: real,
        mass: wp.array(dtype=real),
        density: wp.array(dtype=real),
        q_in: wp.array(dtype=vec3),
        q_out: wp.array(dtype=vec3),
        stress_in: wp.array(dtype=mat33),
        stress_out: wp.array(dtype=mat33),
        pressure_in: wp.array(dtype=wp.float64),
        pressure_out: wp.array(dtype=wp.float64),
        pore_water: int,
        ledger: wp.array2d(dtype=wp.float64),
    ):
        """The work σ̄ (A n)·Δx [J, J/m in 2D] of the tractions the planes a particle lies on put on it,
        σ̄ the step's mean total stress, n each plane's outward normal, A = V/Δx at tⁿ."""
        i = wp.tid()
        a = particle[i]
        s = half * (stress_in[a] + stress_out[a])
        if pore_water != 0:
            p = half * real(pressure_in[a] + pressure_out[a])
            s = s - p * wp.identity(3, dtype=real)
        area = mass[a] / (density[a] * spacing)
        moved = q_out[a] - q_in[a]
        planes = planes_of[i]
        work = real(0.0)
        for c in range(3):
            if planes[c] >= 0:
                normal = vec3(real(0.0), real(0.0), real(0.0))
                normal[plane_axis[planes[c]]] = plane_sign[planes[c]]
                work += area * wp.dot(s * normal, moved)
        ledger[a, BOUNDARIES] += wp.float64(work)

    return boundary_work


class EnergyLedger:
    """The per-particle ledger (capacity × ``CHANNELS``, float64) the step's kernels add to, and the
    boundary planes' work, added after the step's prescribed values."""

    def __init__(self, model: Model):
        self.model = model
        self.ledger = wp.zeros((model.particle_capacity, CHANNELS), dtype=wp.float64, device=model.device)
        self._no_pressure = wp.zeros(1, dtype=wp.float64, device=model.device)

    def add_boundary_work(self, si: State, so: State, pressure_in=None, pressure_out=None) -> None:
        """The planes' work over the step from ``si`` to ``so`` on the particles lying on them (the
        model's constraint lists); with pore water the pore pressures at both ends."""
        m = self.model
        if not m.constraint_count:
            return
        pore = pressure_in is not None
        launch(_boundary_kernel(m.spec), m.constraint_count,
               [m.constraint_particle, m.constraint_planes, m.plane_axis, m.plane_sign, m.spec.real(m.dx),
                m.particle_mass, si.particle_density, si.particle_q, so.particle_q, si.particle_stress,
                so.particle_stress, pressure_in if pore else self._no_pressure,
                pressure_out if pore else self._no_pressure, int(pore), self.ledger], m.device)  # fmt: skip

    def totals(self) -> np.ndarray:
        """(CHANNELS,) sums over the owned particles."""
        return self.ledger.numpy()[: self.model.particle_count].sum(axis=0)


def stored_energies(model: Model, state: State) -> tuple[float, float]:
    """(kinetic ½ Σ m v², strain Σ V ψ(σ′)) of the owned particles [J, J/m in 2D], ψ the linear law's
    elastic energy density (:func:`~warpsph.physics.elastic.strain_energy_density`), V = m/ρ."""
    n = model.particle_count
    mass = model.particle_mass.numpy()[:n].astype(np.float64)
    v = state.particle_v.numpy()[:n].astype(np.float64)
    stress = state.particle_stress.numpy()[:n].astype(np.float64)
    volume = mass / state.particle_density.numpy()[:n].astype(np.float64)
    material = model.particle_material.numpy()[:n]
    lam = model.material_lambda.numpy().astype(np.float64)[material]
    shear = model.material_shear.numpy().astype(np.float64)[material]
    kinetic = 0.5 * float(np.sum(mass * np.einsum("ni,ni->n", v, v)))
    return kinetic, float(np.sum(volume * strain_energy_density(stress, lam, shear)))


def energy_balance(model: Model, state: State, totals: np.ndarray, start: tuple[float, float]) -> dict[str, float]:
    """The balance since the phase's start [J, J/m in 2D]: kinetic and strain energy (their changes from
    ``start``), the dissipations and works of the ledger's ``totals``, ``error`` = energy stored and
    lost less the work given, and ``error_ratio`` = |error| over the energy turned over (the larger of
    the two sides' magnitudes)."""
    kinetic, strain = stored_energies(model, state)
    out = {"kinetic": kinetic - start[0], "strain": strain - start[1]}
    out.update({name: float(totals[k]) for name, k in DISSIPATIONS.items()})
    out.update({name: float(totals[k]) for name, k in WORKS.items()})
    held = [out["kinetic"], out["strain"], *(out[k] for k in DISSIPATIONS)]
    given = [out[k] for k in WORKS]
    out["error"] = sum(held) - sum(given)
    scale = max(sum(map(abs, held)), sum(map(abs, given)))
    out["error_ratio"] = abs(out["error"]) / scale if scale > 0.0 else 0.0
    return out


def balance_warnings(balance: dict[str, float]) -> list[str]:
    """One line per energy check the balance fails: stabilisation energy above
    ``STABILISATION_WARNING`` of the strain energy's change, an error above ``BALANCE_WARNING``."""
    out = []
    stabilisation, strain = abs(balance["stabilisation_dissipation"]), abs(balance["strain"])
    if stabilisation > STABILISATION_WARNING * strain and stabilisation > 0.0:
        out.append(f"the stabilisation's energy {balance['stabilisation_dissipation']:.4g} J is "
                   f"{stabilisation / max(strain, 1e-300):.3g} times the strain energy's change "
                   f"(more than {STABILISATION_WARNING:g})")  # fmt: skip
    if balance["error_ratio"] > BALANCE_WARNING:
        out.append(f"the energy balance misses by {balance['error']:.4g} J, {100 * balance['error_ratio']:.3g} % "
                   f"of the energy turned over (more than {100 * BALANCE_WARNING:g} %)")  # fmt: skip
    return out
