"""Energy balance: each real particle's ledger of the work done on it and the energy it lost.

The step's kernels add to a particle's row as they change its state; the kinetic and strain energies
are states, read with the ledger's sums at output times, so no step waits on the host. What each
column holds and what the balance measures: docs/method.md, *Energy balance*.
"""


import functools

import numpy as np
import warp as wp

from warpsph.launching import launch
from warpsph.model import PLANE_SLIP, Model, State
from warpsph.physics.elastic import elastic_struct, strain_energy_function
from warpsph.sph.spec import Spec

PLASTIC, PORE_WATER, VISCOUS, STABILISATION, GRAVITY, BOUNDARIES, RIGID, DAMPING = range(8)
"""Columns of the ledger: dissipations (plastic, viscous, stabilisation, damping) are counted as
energy lost, works (gravity, boundaries, rigid regions, pore water) as energy given."""
CHANNELS = 8
KINETIC, STRAIN, LEDGER = 0, 1, 2
"""Entries of :meth:`EnergyLedger.sums`: kinetic energy, strain energy, then the ledger's columns."""
DISSIPATIONS = {"plastic_dissipation": PLASTIC, "viscous_dissipation": VISCOUS,
                "stabilisation_dissipation": STABILISATION, "damping_dissipation": DAMPING}  # fmt: skip
WORKS = {"gravity_work": GRAVITY, "boundary_work": BOUNDARIES, "rigid_load_work": RIGID,
         "pore_water_work": PORE_WATER}  # fmt: skip
HELD = ("kinetic", "strain", *DISSIPATIONS)
"""The balance's entries of energy stored (their changes) and lost."""
STABILISATION_WARNING = 0.1
"""Stabilisation energy above this fraction of the strain energy's change is reported."""
BALANCE_WARNING = 0.01
"""A balance that misses by more than this fraction of the energy turned over is reported."""


def ledger_columns(spec: Spec) -> dict[int, int]:
    """The column of each channel in the ledger of ``spec``'s variant: every channel but the plastic one
    without plasticity and the pore water's without pore water, in channel order."""
    effects = spec.effects
    absent = {PLASTIC} if not effects.plasticity else set()
    absent |= {PORE_WATER} if not effects.pore_water else set()
    return {channel: k for k, channel in enumerate(c for c in range(CHANNELS) if c not in absent)}


@functools.cache
def _boundary_kernel(spec: Spec):
    column = ledger_columns(spec)  # the energy ledger's column of each channel
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    half = real(0.5)

    @wp.kernel(enable_backward=False, module="unique")
    def boundary_work(
        particle: wp.array(dtype=wp.int32),
        planes_of: wp.array(dtype=wp.vec3i),
        plane_axis: wp.array(dtype=wp.int32),
        plane_sign: wp.array(dtype=real),
        plane_kind: wp.array(dtype=wp.int32),
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
        """The work t·Δx [J, J/m in 2D] of the tractions t the planes a particle lies on put on it: σ̄ A n
        on a fixed, velocity or traction plane, its normal part alone on a slip plane (which holds no
        shear), σ̄ the step's mean total stress, n the plane's outward normal, A = V/Δx at tⁿ."""
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
                traction = s * normal
                if plane_kind[planes[c]] == PLANE_SLIP:
                    traction = wp.dot(traction, normal) * normal
                work += area * wp.dot(traction, moved)
        ledger[a, wp.static(column[BOUNDARIES])] += wp.float64(work)

    return boundary_work


@functools.cache
def _sum_kernel(spec: Spec):
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    psi = strain_energy_function(spec)
    ElasticMaterials = elastic_struct(spec)

    @wp.kernel(enable_backward=False, module="unique")
    def sum_energies(
        mass: wp.array(dtype=real),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        density: wp.array(dtype=real),
        material: wp.array(dtype=wp.int32),
        elastic: ElasticMaterials,
        ledger: wp.array2d(dtype=wp.float64),
        channel_of: wp.array(dtype=wp.int32),
        sums: wp.array(dtype=wp.float64),
    ):
        a = wp.tid()
        mat = material[a]
        wp.atomic_add(sums, KINETIC, wp.float64(real(0.5) * mass[a] * wp.dot(v[a], v[a])))
        strain = psi(stress[a], elastic.lam[mat], elastic.shear[mat])
        wp.atomic_add(sums, STRAIN, wp.float64(mass[a] / density[a] * strain))
        for c in range(ledger.shape[1]):
            wp.atomic_add(sums, LEDGER + channel_of[c], ledger[a, c])

    return sum_energies


class EnergyLedger:
    """The per-particle ledger (capacity × the variant's channels, float64: :func:`ledger_columns`) the
    step's kernels add to, and the boundary planes' work, added after the step's prescribed values."""

    def __init__(self, model: Model):
        self.model = model
        channels = list(ledger_columns(model.spec))
        self.ledger = wp.zeros((model.particle_capacity, len(channels)), dtype=wp.float64, device=model.device)
        self._channel_of = wp.array(channels, dtype=wp.int32, device=model.device)
        self._no_pressure = wp.zeros(1, dtype=wp.float64, device=model.device)
        self._sums = wp.zeros(LEDGER + CHANNELS, dtype=wp.float64, device=model.device)

    def add_boundary_work(self, si: State, so: State, pressure_in=None, pressure_out=None) -> None:
        """The planes' work over the step from ``si`` to ``so`` on the particles lying on them (the
        model's constraint lists); with pore water the pore pressures at both ends."""
        m = self.model
        if not m.constraint_count:
            return
        pore = pressure_in is not None
        launch(_boundary_kernel(m.spec), m.constraint_count,
               [m.constraint_particle, m.constraint_planes, m.plane_axis, m.plane_sign, m.plane_kind, m.spec.real(m.dx),
                m.particle_mass, si.particle_density, si.particle_q, so.particle_q, si.particle_stress,
                so.particle_stress, pressure_in if pore else self._no_pressure,
                pressure_out if pore else self._no_pressure, int(pore), self.ledger], m.device)  # fmt: skip

    def sum_on_device(self, state: State) -> wp.array:
        """(``LEDGER`` + ``CHANNELS``,) sums over the owned particles of ``state``, made on the device and
        left there: the kinetic energy ½ m v², the strain energy V ψ(σ′) (ψ the linear law's elastic
        energy density, :func:`~warpsph.physics.elastic.strain_energy_function`, V = m/ρ), then the
        ledger's channels [J, J/m in 2D] (0 for those the variant's ledger does not hold)."""
        m = self.model
        self._sums.zero_()
        launch(_sum_kernel(m.spec), m.particle_count,
               [m.particle_mass, state.particle_v, state.particle_stress, state.particle_density, m.particle_material,
                m.material_elastic, self.ledger, self._channel_of, self._sums], m.device)  # fmt: skip
        return self._sums

    def sums(self, state: State) -> np.ndarray:
        """:meth:`sum_on_device`, read at once."""
        return self.sum_on_device(state).numpy().copy()  # on the CPU, numpy() is a view of the device array


SIGNS = np.zeros(LEDGER + CHANNELS)
"""+1 for the entries of :meth:`EnergyLedger.sums` held (stored and lost), −1 for the works given: the
balance's error is Σ sign × change."""
SIGNS[[KINETIC, STRAIN, *(LEDGER + k for k in DISSIPATIONS.values())]] = 1.0
SIGNS[[LEDGER + k for k in WORKS.values()]] = -1.0
NOT_FOUND = wp.constant(2**31 - 1)


@wp.kernel(enable_backward=False)
def _growth_kernel(
    step: int,
    sums: wp.array(dtype=wp.float64),
    start: wp.array(dtype=wp.float64),
    signs: wp.array(dtype=wp.float64),
    limit: wp.float64,
    growth: wp.float64,
    progress: wp.array(dtype=wp.float64),
    found: wp.array(dtype=wp.int32),
    what: wp.array(dtype=wp.float64),
):
    """One window of the guard of :class:`EnergyGuard`: ``progress`` = [error at the window's start,
    the energy made by the last three windows, windows counted]; ``found`` the first step it grew at
    and ``what`` [energy made by the last window, its fraction of the energy in play, over the first's]."""
    error = wp.float64(0.0)
    held = wp.float64(0.0)
    given = wp.float64(0.0)
    for k in range(sums.shape[0]):
        change = sums[k] - start[k]
        error += signs[k] * change
        if signs[k] > wp.float64(0.0):
            held += wp.abs(change)
        if signs[k] < wp.float64(0.0):
            given += wp.abs(change)
    scale = wp.max(wp.max(held, given), start[0] + start[1])
    window = error - progress[0]
    made = wp.float64(0.0)
    if scale > wp.float64(0.0):
        made = wp.max(window, wp.float64(0.0)) / scale
    progress[0] = error
    progress[1] = progress[2]
    progress[2] = progress[3]
    progress[3] = window
    progress[4] = progress[4] + wp.float64(1.0)
    w0 = progress[1]
    w1 = progress[2]
    rising = progress[4] >= wp.float64(3.0) and w0 > wp.float64(0.0) and w0 < w1 and w1 < window
    if found[0] == NOT_FOUND and made > limit and rising and window > growth * w0:
        found[0] = step
        what[0] = window
        what[1] = made
        what[2] = window / w0


class EnergyGuard:
    """The run guard's check of the energy balance, on the device with no read (:meth:`mark`): after
    three windows of steps each of which made more energy from nothing than the one before, the last
    more than ``limit`` of the energy in play and more than ``growth`` times the first, it keeps the
    step; :meth:`read` reads it at the run's output cadence."""

    def __init__(self, ledger: EnergyLedger, limit: float, growth: float):
        device = ledger.model.device
        self.ledger, self.limit, self.growth = ledger, limit, growth
        self.start = wp.zeros(LEDGER + CHANNELS, dtype=wp.float64, device=device)
        self.signs = wp.array(SIGNS, dtype=wp.float64, device=device)
        self.progress = wp.zeros(5, dtype=wp.float64, device=device)
        self.found = wp.zeros(1, dtype=wp.int32, device=device)
        self.what = wp.zeros(3, dtype=wp.float64, device=device)

    def begin(self, start, since: float = 0.0, windows=()) -> None:
        """Measure from the sums ``start``; a resumed run's error so far and its last windows' energies."""
        windows = list(windows)[-3:]
        self.start.assign(np.asarray(start, dtype=np.float64))
        self.progress.assign(np.array([since, *([0.0] * (3 - len(windows))), *windows, len(windows)], dtype=np.float64))
        self.found.fill_(NOT_FOUND)

    def mark(self, state: State, step: int) -> None:
        """Check the windows up to the state after step ``step`` on the device."""
        sums = self.ledger.sum_on_device(state)
        wp.launch(_growth_kernel, 1, [step, sums, self.start, self.signs, wp.float64(self.limit),
                                      wp.float64(self.growth), self.progress, self.found, self.what],
                  device=self.ledger.model.device)  # fmt: skip

    def read(self) -> tuple[int, float, float, float] | None:
        """(the step the energy made grew at, what the last window made [J], its fraction of the energy
        in play, its ratio to the first window's), or None."""
        step = int(self.found.numpy()[0])
        return None if step == NOT_FOUND else (step, *map(float, self.what.numpy()))

    def progress_so_far(self) -> tuple[float, list[float]]:
        """(the balance's error at the last window's end, the last windows' energies), for a checkpoint."""
        p = self.progress.numpy()
        count = int(min(p[4], 3))
        return float(p[0]), [float(w) for w in p[4 - count:4]]


def energy_balance(now: np.ndarray, start: np.ndarray) -> dict[str, float]:
    """The balance between two :meth:`EnergyLedger.sums` [J, J/m in 2D]: the changes of kinetic and strain
    energy, the dissipations and works booked in between, ``error`` = energy stored and lost less the
    work given (positive: energy the step made), and ``error_ratio`` = |error| over the energy turned
    over (the larger of the two sides' magnitudes)."""
    change = np.asarray(now, dtype=np.float64) - np.asarray(start, dtype=np.float64)
    out = {"kinetic": float(change[KINETIC]), "strain": float(change[STRAIN])}
    out.update({name: float(change[LEDGER + k]) for name, k in DISSIPATIONS.items()})
    out.update({name: float(change[LEDGER + k]) for name, k in WORKS.items()})
    out["error"] = sum(out[k] for k in HELD) - sum(out[k] for k in WORKS)
    scale = turned_over(out)
    out["error_ratio"] = abs(out["error"]) / scale if scale > 0.0 else 0.0
    return out


def turned_over(balance: dict[str, float]) -> float:
    """The energy a balance turned over [J, J/m in 2D]: the larger of the magnitudes of what was stored
    and lost and of what was given."""
    return max(sum(abs(balance[k]) for k in HELD), sum(abs(balance[k]) for k in WORKS))


def energy_made(balance: dict[str, float], since: float, start: np.ndarray) -> float:
    """The energy the steps made since the balance's error was ``since`` [J, J/m in 2D] (0 where they
    lost energy), as a fraction of the energy in play: the larger of the energy turned over and the
    energy stored at the start. An unstable mode makes energy from nothing in proportion to the
    energy it holds, so the fraction over a fixed number of steps stays high as it grows."""
    scale = max(turned_over(balance), float(start[KINETIC] + start[STRAIN]))
    return max(balance["error"] - since, 0.0) / scale if scale > 0.0 else 0.0


def energy_unit(dim: int) -> str:
    """The unit of an energy of a ``dim``-D run: per unit of the unmodelled extent in 1D and 2D."""
    return {1: "J/m²", 2: "J/m"}.get(dim, "J")


def balance_warnings(balance: dict[str, float], dim: int = 3) -> list[str]:
    """One line per energy check the balance of a ``dim``-D run fails: stabilisation energy above
    ``STABILISATION_WARNING`` of the strain energy's change, an error above ``BALANCE_WARNING``; each
    says what to read next (docs/method.md, *Energy balance*)."""
    out, unit = [], energy_unit(dim)
    stabilisation, strain = abs(balance["stabilisation_dissipation"]), abs(balance["strain"])
    if stabilisation > STABILISATION_WARNING * strain and stabilisation > 0.0:
        out.append(f"the stabilisation's energy {balance['stabilisation_dissipation']:.4g} {unit} is "
                   f"{stabilisation / max(strain, 1e-300):.3g} times the strain energy's change "
                   f"(more than {STABILISATION_WARNING:g}): the surface band's traction term and the filters did "
                   f"that work; the series energy_stabilisation_dissipation shows when (docs/method.md, Energy "
                   f"balance)")  # fmt: skip
    if balance["error_ratio"] > BALANCE_WARNING:
        out.append(f"the energy balance misses by {balance['error']:.4g} {unit}, {100 * balance['error_ratio']:.3g} % "
                   f"of the energy turned over (more than {100 * BALANCE_WARNING:g} %): a miss that grows step "
                   f"after step is an instability, one made once as the phase starts is not; the series "
                   f"energy_error shows which (docs/method.md, Energy balance)")  # fmt: skip
    return out
