"""Groundwater flow through the fixed skeleton: the flow phase's implicit steps (docs/method.md,
*Groundwater flow*).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from warpsph.launching import launch_rows
from warpsph.model import Model, State
from warpsph.pore_water import PlaneDrainage
from warpsph.scene import STANDARD_GRAVITY
from warpsph.stages.groundwater_kernels import WaterContent, groundwater_kernels
from warpsph.stages.linear_solve import LinearSolver, sparse_rows
from warpsph.stages.surface_water import wetted_regions

MAX_ITERATIONS = 40
"""Picard iterations of one transient step before it is retried with half the time step."""
SEEPAGE_ITERATIONS = 15
"""Iterations of a step in which seepage-face particles may be held or released; later ones keep the
set (where the exit point lay between two particles, one was released and held in turn and the
iteration did not converge)."""
STEP_CHANGE = 0.005
"""Accuracy of a transient step: the largest change of pore pressure it may make where the water
content follows the pressure (off the held rows and the seepage faces), as a fraction of ρ_w g times
the bodies' height [-];
a step that changes more is retried shorter, and the next step is sized from this one's change (at
most 1.5 times longer)."""


class GroundwaterFlow:
    """The flow phase's solver on ``model``'s fixed configuration in ``state`` (``solver``: the
    phase's :class:`~warpsph.solver.Solver`, whose ghosts, neighbour lists and corrections give
    the geometry once); ``reservoirs``: the phase's :class:`~warpsph.scene.Reservoir` list."""

    def __init__(self, model: Model, solver, state: State, reservoirs: list, tolerance: float, height: float):
        self.model, self.state = model, state
        m, pw, dev = model, model.pore, model.device
        n = m.particle_count
        self.k = groundwater_kernels(m.spec)
        solver.fit_geometry(state)
        self.projection = solver.projection
        self.lists = solver.real_to_real
        self.reservoirs = reservoirs
        x = state.particle_q.numpy()[:n].astype(np.float64)  # the fixed skeleton's positions
        rho_w = pw.water.density.numpy()[m.particle_material.numpy()[:n]]
        self.rho_g = rho_w * float(np.linalg.norm(pw.gravity))
        self.hydro = pw.hydrostatic(x, rho_w)
        """p_h at the particles [Pa], as the kernels take it (at their current positions)."""
        self.y = x[:, 1]
        self.surface = self.projection.free_surface_particles()
        self.in_reservoir = wetted_regions(reservoirs, x, self.surface, m.dx)
        self.scale = STANDARD_GRAVITY * 1000.0 * max(height, m.dx)
        """ρ_w g times the bodies' height [Pa]: the scale of the pressure changes."""
        self.tolerance = tolerance * self.scale
        """Largest pressure change of a converged iteration [Pa]."""
        self.n_tags = m.plane_count + 1 + len(reservoirs)
        """Discharge tags: the planes, the seepage faces, then the reservoirs."""
        f64 = wp.float64
        zeros = lambda size, dtype=f64: wp.zeros(size, dtype=dtype, device=dev)  # noqa: E731
        self.saturation, self.capacity, self.relative = zeros(n), zeros(n), zeros(n)
        self.saturation_start = zeros(n)
        self.p_iter, self.p_start = zeros(n), zeros(n)
        self.dirichlet, self.value, self.tag = zeros(n, wp.int32), zeros(n), zeros(n, wp.int32)
        self.diag, self.rhs, self.released, self.stored = zeros(n), zeros(n), zeros(n), zeros(n)
        self.increment, self.increment_rhs = zeros(n), zeros(n)
        self.coupling_storage, self.coupling_source = zeros(n), zeros(n)
        """β [1/Pa] and s [-] of a consolidation step's rows (:mod:`warpsph.stages.consolidation`); zero
        in a flow phase."""
        self.content = WaterContent()
        """The arrays above as the flow's kernels take them."""
        for name in ("saturation", "capacity", "relative", "saturation_start", "p_start", "coupling_storage",
                     "coupling_source"):
            setattr(self.content, name, getattr(self, name))
        self.discharge_rows = zeros(n * self.n_tags)
        size = max(1, self.lists.indices.shape[0])
        self.weight = zeros(size)
        self.drainage = PlaneDrainage(model)
        self.drained = solver.boundaries.with_drainage(self.drainage)
        """The planes with the flow's own prescribed values, as the kernels take them."""
        self.linear = LinearSolver(n, dev, m.scene.pressure)
        self.seeping = (self.surface & (self._excess() + self.hydro >= 0.0)).astype(np.int32)
        """1 on the seepage-face particles held at atmospheric pressure (water leaves there)."""
        self.iterations = 0
        self.largest_change = 0.0
        """The last step's largest pressure change off the held rows [Pa]."""
        self.step_change = 0.0
        """``largest_change`` over STEP_CHANGE × ``scale`` [-]."""
        self.discharge: dict[str, float] = {}
        """The last step's discharge [m³/s, per metre in 2D] out of the body through each boundary,
        load, seepage face and reservoir that passes water (negative: into it)."""
        self.storage_rate = 0.0
        """The last step's rate of growth of the water held in the body [m³/s, per metre in 2D]."""

    def _excess(self) -> np.ndarray:
        """A host copy of the owned particles' excess pore pressure (on the CPU ``numpy()`` is a view)."""
        return self.state.particle_pore_pressure.numpy()[: self.model.particle_count].copy()

    # -- conditions -----------------------------------------------------------------------------
    def _conditions(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows held at a value at time t: (dirichlet, value, tag, candidate seepage rows)."""
        m = self.model
        self.drainage.set_time(t)
        dirichlet, value, tag = self.drainage.on.copy(), self.drainage.value.copy(), self.drainage.plane.copy()
        seepage_tag = m.plane_count
        free = self.surface.copy()
        for r, (res, inside) in enumerate(zip(self.reservoirs, self.in_reservoir)):
            level = res.level * res.time_function(t)
            wet = inside & free & (self.y <= level)
            dirichlet[wet], tag[wet] = 1, seepage_tag + 1 + r
            value[wet] = self.rho_g[wet] * (level - self.y[wet]) - self.hydro[wet]
            free &= ~wet
        value[free], tag[free] = -self.hydro[free], seepage_tag
        return dirichlet, value, np.maximum(tag, 0), free

    def hold_prescribed(self, t: float) -> None:
        """Set the state's excess pore pressure to its prescribed value at time ``t`` on the rows held
        there (drained planes, faces a reservoir wets), the other rows as they are."""
        held, value, _tag, _candidates = self._conditions(t)
        n = self.model.particle_count
        p = self.state.particle_pore_pressure.numpy().copy()
        p[:n][held == 1] = value[held == 1]
        self.state.particle_pore_pressure.assign(p)

    # -- one step -------------------------------------------------------------------------------
    def _args(self, inv_dt: float, p_iter):
        m, pw = self.model, self.model.pore
        nl = self.lists
        return [m.spec.real(m.h), wp.float64(inv_dt), wp.float64(self.projection.scale), m.particle_count,
                nl.offsets, nl.indices, self.state.particle_q, m.particle_origin, m.particle_mass,
                self.state.particle_density, m.particle_material, pw.water, self.content, p_iter,
                m.particle_ghost_source, m.particle_ghost_planes, self.drained, self.dirichlet]  # fmt: skip

    def _retention(self, p, out_saturation=None) -> None:
        m, pw = self.model, self.model.pore
        launch_rows(self.k["retention_fields"], m.particle_count,
                    [self.state.particle_q, m.particle_material, pw.water, pw.retention, p,
                     out_saturation or self.saturation, self.capacity, self.relative], m.device)  # fmt: skip

    def solve(self, t: float, dt: float | None, max_iterations: int = MAX_ITERATIONS,
              start: wp.array | None = None) -> bool:
        """Advance the pore pressure in the state to time ``t`` by one implicit step of ``dt`` [s]
        (None: to the steady state, with up to ``max_iterations`` iterations); False, with the
        pressure put back, if the iteration did not converge. ``start``: the pressures at the step's
        start when the state's are already an iterate of it (a consolidation step's)."""
        m, dev = self.model, self.model.device
        n = m.particle_count
        p = self.state.particle_pore_pressure
        wp.copy(self.p_start, p if start is None else start, count=n)
        if self.lists.indices.shape[0] > self.weight.shape[0]:  # the skeleton moved: its lists grew
            self.weight = wp.zeros(self.lists.indices.shape[0], dtype=wp.float64, device=dev)
        self._seeping_start = self.seeping.copy()
        base, value, tag, candidates = self._conditions(t)
        self.tag.assign(tag)
        inv_dt = 0.0 if dt is None else 1.0 / dt
        self._retention(self.p_start, self.saturation_start)
        relaxation = 1.0
        last_change = np.inf
        for iteration in range(1, max_iterations + 1):
            dirichlet = base | (candidates & (self.seeping == 1))
            self.dirichlet.assign(dirichlet.astype(np.int32))
            self.value.assign(value)
            current = self._excess()
            self.p_iter.assign(current)
            self._retention(self.p_iter)
            args = self._args(inv_dt, self.p_iter)
            launch_rows(self.k["assemble_flow"], n,
                        [*args, self.value, self.projection.face_factor, self.weight, self.diag,
                         self.rhs], dev)  # fmt: skip
            matrix = sparse_rows(self.lists.offsets, self.weight, self.lists.indices, m.particle_ghost_source,
                                 self.diag, n)  # fmt: skip
            launch_rows(self.k["residual"], n, [matrix, self.p_iter, self.rhs, self.increment_rhs, self.increment],
                        dev)  # fmt: skip
            self.linear.solve(matrix, self.increment_rhs, self.increment)
            launch_rows(self.k["add_increment"], n, [self.p_iter, self.increment, p], dev)
            full = self._excess()  # the iteration's own update: it conserves the water
            change = float(np.max(np.abs(full - current), initial=0.0))
            flips = self._update_seepage(args, candidates, full) if iteration <= SEEPAGE_ITERATIONS else 0
            self.iterations = iteration
            if change < self.tolerance and flips == 0:
                self._record(args)
                moved = np.abs(full - self.p_start.numpy())[(dirichlet == 0) & ~candidates & self._stores_water()]
                self.largest_change = float(np.max(moved, initial=0.0))
                self.step_change = self.largest_change / (STEP_CHANGE * self.scale)
                return True
            if change > last_change:  # an iteration changing more than the one before: under-relax
                relaxation = max(0.1, 0.5 * relaxation)
            last_change = change
            if relaxation < 1.0:
                relaxed = current + relaxation * (full - current)
                relaxed[dirichlet == 1] = value[dirichlet == 1]
                p.assign(np.concatenate([relaxed, p.numpy()[n:]]))
        self.undo()
        return False

    def undo(self) -> None:
        """Put the pore pressure and the seepage faces back to the start of the last step."""
        p, n = self.state.particle_pore_pressure, self.model.particle_count
        p.assign(np.concatenate([self.p_start.numpy(), p.numpy()[n:]]))
        self.seeping = self._seeping_start.copy()

    def _balance(self, args) -> None:
        m = self.model
        launch_rows(self.k["flow_balance"], m.particle_count,
                    [*args, self.projection.face_factor, self.tag, self.n_tags, self.state.particle_pore_pressure,
                     self.released, self.discharge_rows, self.stored], m.device)  # fmt: skip

    def _update_seepage(self, args, candidates: np.ndarray, p: np.ndarray) -> int:
        """Hold the seepage rows whose pressure rose above the atmosphere's; release those into which
        water would flow (their own equation gives less than it); the number changed."""
        self._balance(args)
        total = p + self.hydro
        released = self.released.numpy() + self.hydro
        margin = self.tolerance
        hold = candidates & (self.seeping == 0) & (total > margin)
        free = candidates & (self.seeping == 1) & (released < -margin)
        self.seeping[hold] = 1
        self.seeping[free] = 0
        return int(hold.sum() + free.sum())

    def _record(self, args) -> None:
        """The step's discharge through each named boundary and the storage rate."""
        self._balance(args)
        rows = self.discharge_rows.numpy().reshape(-1, self.n_tags)
        totals = rows.sum(axis=0)
        names = list(self.model.plane_names) + ["seepage"] + [r.name for r in self.reservoirs]
        self.discharge = {}
        for name, value in zip(names, totals):
            self.discharge[name] = self.discharge.get(name, 0.0) + float(value)
        self.storage_rate = float(np.sum(self.stored.numpy()[self.dirichlet.numpy() == 0]))
        self._retention(self.state.particle_pore_pressure)

    def _stores_water(self) -> np.ndarray:
        """Mask of the rows whose water content changes with their pressure (n dS/dp + S/Q > 0); the
        others (saturated soil of incompressible water) follow the rest at once, whatever the step."""
        m = self.model
        inv_biot = m.pore.water.inv_biot.numpy()[m.particle_material.numpy()[: m.particle_count]]
        storage = self.capacity.numpy() + self.saturation.numpy() * inv_biot + self.coupling_storage.numpy()
        return storage > 0.0

    def saturation_field(self) -> np.ndarray:
        """(N,) degree of saturation [-] of the current state (host)."""
        self._retention(self.state.particle_pore_pressure)
        return self.saturation.numpy().copy()
