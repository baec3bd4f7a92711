"""Pore-pressure projection of the fractional step, in float64 throughout: the pressure at tⁿ⁺¹ from the
water mass balance, then the velocity correction (docs/method.md, *Saturated soil*).
"""

import warnings

import numpy as np
import warp as wp

from warpsph.errors import SimulationError
from warpsph.launching import launch, launch_rows
from warpsph.model import PLANE_TRACTION, Model
from warpsph.pore_water import PlaneDrainage
from warpsph.stages.corrections import compute_volumes
from warpsph.stages.linear_solve import LinearSolver, sparse_rows
from warpsph.stages.pressure_kernels import (
    DRAINED_SURFACE_EIGENVALUE,
    LOW_PERMEABILITY_WEIGHT,
    faded_by_draining,
    laplacian_scale,
    lattice_morris_sum,
    pressure_kernels,
)
from warpsph.stages.surface_water import wetted_regions

STABLE_SURFACE_RATIO = {"drained": 0.015, "impermeable": 0.01}
"""k ρ/Δt (the Darcy part of the projection's Laplacian over its Δt/ρ part) from which a free surface
of each kind is stable at every Courant number measured without the roughness damping
(``pressure.stabilisation`` = 0; also used below 1, where it was not measured). One step about rest
then has a real eigenvalue above 1, a pore pressure mode under the surface: for a drained surface
(whose band pushes with the total stress extrapolated to the surface) at 0.0071, 0.0071, 0.0028 and
0.0016 and not at 0.0142, 0.0142, 0.0047 and 0.0026 at Courant 0.05, 0.1, 0.5 and 0.9 (1D and 2D
columns, growing at up to 24 /s); for an impermeable one below about 0.003 at Courant 0.5 and 0.005
at 0.9, growing at up to 9 /s (docs/method.md, *Known limits*)."""
DAMPED_STABLE_SURFACE_RATIO = {"drained": 0.0, "impermeable": 0.0}
"""The same with the roughness damping at full weight (θ = 1): impermeable and drained surfaces
stable down to k_h = 1e-12 m/s at Courant 0.1–0.9 (1D column; drained also a 2D one)."""
NEGLIGIBLE_WEIGHT = 1e-3
"""Relative weight below which the roughness damping away from free surfaces and sealed faces is not
computed: where every material in use drains k ρ/Δt > 0.19 a step (e.g. Terzaghi's set A, 0.24)."""


class PressureProjection:
    """Assembles and solves the pressure equation and corrects the velocity (two-set scheme)."""

    def __init__(self, model: Model, solver):
        self.model, self.solver = model, solver
        self.drainage = PlaneDrainage(model)
        """The planes' drained values at the step's time (:meth:`set_time`)."""
        self.planes = solver.boundaries.with_drainage(self.drainage)
        """The planes as the kernels take them (the boundaries' positions, moved in place with the planes)."""
        m, dev = model, model.device
        n, ne, nv = m.particle_count, m.particle_capacity, m.virtual_capacity
        f64 = wp.float64
        self.k = pressure_kernels(m.spec)
        settings = m.scene.pressure
        self.settings = settings
        ratio = m.scene.simulation.smoothing_ratio
        self.scale = laplacian_scale(m.spec.kernel, m.spec.dim, ratio)
        self.lattice_sum = lattice_morris_sum(m.spec.kernel, m.spec.dim, m.dx, ratio)
        impermeable_surface = settings.free_surface == "impermeable"
        self.exterior_threshold = solver.config.free_surface_threshold if impermeable_surface else 0.0
        """Correction eigenvalue below which a particle gains the exterior pairs (0: none do)."""
        self.water_on_surface = 1.0 if impermeable_surface else 0.0
        """Weight of the pore pressure in the surface band's weak traction term: 1 at an impermeable free
        surface (pushed as if the pressure were zero outside), 0 at a drained one, whose Dirichlet rows
        hold the zero pressure that the fitted gradient already carries (pushing with the particle's
        own pressure as well fed back on it: docs/method.md, *Drained free surfaces*)."""
        self.div_v_star = wp.zeros(n, dtype=f64, device=dev)
        self.virtual_v_star = wp.zeros(nv, dtype=m.spec.vec3, device=dev)
        self.p_old = wp.zeros(ne, dtype=f64, device=dev)
        self.dp = wp.zeros(ne, dtype=f64, device=dev)
        self.virtual_dp = wp.zeros(nv, dtype=f64, device=dev)
        self.grad = wp.zeros(n, dtype=wp.vec3d, device=dev)
        self.dirichlet = wp.zeros(n, dtype=wp.int32, device=dev)
        self.value = wp.zeros(n, dtype=f64, device=dev)
        self.diag = wp.zeros(n, dtype=f64, device=dev)
        self.rhs = wp.zeros(n, dtype=f64, device=dev)
        self.roughness = wp.zeros(n, dtype=f64, device=dev)
        self.near_surface = wp.zeros(n, dtype=wp.int32, device=dev)
        self.linear = LinearSolver(n, dev, settings)
        self.weight = None
        on = self.drainage.on
        self.on_drained = wp.array(on, dtype=wp.int32, device=dev)
        self.face_factor = wp.array(self._face_factor(), dtype=f64, device=dev)
        image = self._momentum_image(on)
        self.momentum_image = wp.array(image, dtype=f64, device=dev)
        self.sealed_face = wp.array((image == 0.0).astype(np.int32), dtype=wp.int32, device=dev)
        """1 on the particles of impermeable traction planes (loaded sealed faces), whose pressure is
        extrapolated from their neighbours after each solve (``extrapolate_to_sealed_faces``)."""
        self.has_sealed_faces = bool(np.any(image == 0.0))
        self.damps_everywhere = settings.interior_stabilisation > 0.0 or (
            settings.stabilisation > 0.0 and self._low_permeability_weight() > NEGLIGIBLE_WEIGHT)
        """Whether the roughness is computed at every particle, not only near free surfaces and sealed faces."""
        self.drained_value = wp.array(self.drainage.value, dtype=f64, device=dev)
        self.iterations: list[int] = []
        self.residuals: list[float] = []
        self.failures = 0
        self._surface_checked = False
        self.surface_warning: str | None = None
        """The warning of ``_warn_unstable_free_surface``, if the run's free surface is in that regime."""

    def reset_statistics(self) -> None:
        """Forget the solves so far (the runner's warm-up step is not part of the run)."""
        self.iterations.clear()
        self.residuals.clear()
        self.failures = 0
        self._surface_checked = False  # its warning, if any, comes again with the run's first step
        self.surface_warning = None

    def _low_permeability_weight(self) -> float:
        """Largest weight, relative to ``pressure.stabilisation``, of the roughness damping away from free
        surfaces and sealed faces: LOW_PERMEABILITY_WEIGHT faded by the least draining material in use."""
        m = self.model
        materials = list(m.scene.materials.values())
        permeability = m.pore.water.permeability.numpy()
        draining = min(permeability[i] * materials[i].density / m.scene.time_step
                       for i in np.unique(m.particle_material.numpy()[: m.particle_count]))
        return float(faded_by_draining(wp.float64(LOW_PERMEABILITY_WEIGHT), wp.float64(draining)))

    def _face_factor(self) -> np.ndarray:
        """½ per plane a particle lies on: the share of its cell inside the body. Scaling its row by
        it keeps the matrix symmetric once ghosts are folded onto their sources (a particle on a
        plane is its own mirror, so it meets each neighbour's mirror as well as the neighbour)."""
        m = self.model
        factor = np.ones(m.particle_count)
        for a, planes in zip(m.constraint_particle.numpy(), m.constraint_planes.numpy().reshape(-1, 3)):
            factor[a] = 0.5 ** int(np.count_nonzero(planes >= 0))
        return factor

    def _momentum_image(self, on_drained: np.ndarray) -> np.ndarray:
        """Weight of each owned particle as a neighbour in the Δt/ρ part of the matrix: 0 on an
        impermeable traction plane, else 1. A particle on a plane stands for itself and its mirror
        images, which coincide with it; the increment is odd across such a plane (``ghost_affine``),
        so the images' mean is zero there. The particle's own row already sees its neighbours'
        mirrors that way: without this the matrix was not symmetric (CG stalled on a loaded block,
        docs/method.md). On a drained plane the particle is a Dirichlet row and keeps weight 1."""
        m = self.model
        image = np.ones(m.particle_count)
        kinds = m.plane_kind.numpy()
        held = m.plates.plate_of  # a plate holds its particles as a wall does: not a traction plane there
        for a, planes, plate in zip(m.constraint_particle.numpy(), m.constraint_planes.numpy().reshape(-1, 3), held):
            traction = [p for p in planes[planes >= 0] if kinds[p] == PLANE_TRACTION and p != plate]
            if on_drained[a] == 0 and traction:
                image[a] = 0.0
        return image

    def update_ghosts(self, q, p, homogeneous: bool, virtual: bool = False, momentum: bool = False) -> None:
        """Pressure-parity values of the ghosts of the real (or virtual) set in ``p`` (with ``momentum``:
        the parity of a pressure increment in the velocity correction, see ``ghost_affine``)."""
        m, pw = self.model, self.model.pore
        if virtual:
            n, src, chain, mat, count, origin = (
                m.virtual_count, m.virtual_ghost_source, m.virtual_ghost_planes, m.virtual_material,
                m.virtual_ghost_count, m.virtual_origin)  # fmt: skip
        else:
            n, src, chain, mat, count, origin = (m.particle_count, m.particle_ghost_source, m.particle_ghost_planes,
                                                 m.particle_material, m.particle_ghost_count,
                                                 m.particle_origin)  # fmt: skip
        launch(self.k["pressure_ghosts"], count,
               [n, src, chain, q, origin, mat, self.planes, pw.water, int(homogeneous), int(momentum), p],
               m.device)  # fmt: skip

    def set_time(self, t: float) -> None:
        """The drained planes' values at time ``t`` [s] of the phase, where a drainage time function
        changes them."""
        if self.drainage.changing and self.drainage.set_time(t):
            self.drained_value.assign(self.drainage.value)

    # -- the projection ---------------------------------------------------------------------------
    def project(self, si, so, dt: float) -> None:
        """Given v* in ``so.particle_v`` and pⁿ in ``si``, solve for pⁿ⁺¹ into ``so`` and correct v."""
        m, pw, sol = self.model, self.model.pore, self.solver
        real, dev, n = m.spec.real, m.device, m.particle_count
        h = real(m.h)
        rf, vf = sol.real_fits, sol.virtual_fits
        # ∇·v* along real → virtual → real (geometry at tⁿ, v* with kinematic ghost parities)
        sol.boundaries.update_real_ghosts(si.particle_q, so.particle_v, so.particle_stress, so.particle_density,
                                          si.particle_pore_pressure)
        nl_v = sol.virtual_to_real
        launch_rows(self.k["fit_vector_at_virtual"], m.virtual_count,
               [h, nl_v.offsets, nl_v.indices, si.virtual_q, vf.struct, si.particle_q, sol.real_volume,
                so.particle_v, self.virtual_v_star], dev)  # fmt: skip
        sol.boundaries.update_virtual_ghosts(si.virtual_q, self.virtual_v_star, sol.virtual_stress,
                                             si.virtual_density, sol.virtual_p)  # fmt: skip
        nl_r = sol.real_to_virtual
        launch_rows(self.k["divergence_at_real"], n,
               [h, nl_r.offsets, nl_r.indices, si.particle_q, rf.struct, si.virtual_q, sol.virtual_volume,
                self.virtual_v_star, self.div_v_star], dev)  # fmt: skip
        # assemble on the real-real list
        nl = sol.real_to_real
        if self.weight is None or self.weight.shape[0] < nl.indices.shape[0]:
            size = nl.indices.shape[0]
            self.weight = wp.zeros(size, dtype=wp.float64, device=dev)
        wp.copy(self.p_old, si.particle_pore_pressure)
        # the solve's unknown: a copy of pⁿ (owned part), drained rows at their values
        x = so.particle_pore_pressure
        wp.copy(x, self.p_old, count=n)
        drained_surface = int(self.settings.free_surface == "drained")
        launch(self.k["mark_dirichlet"], n,
               [0, n, self.on_drained, self.drained_value, rf.smallest_eigenvalue, drained_surface, si.particle_q,
                m.particle_material, pw.water, pw.surface_water, self.dirichlet, self.value, x],
               dev)  # fmt: skip
        if not self._surface_checked:
            self._surface_checked = True
            self._warn_unstable_free_surface(si, dt)
            self.check_reservoirs(si)
        # the arguments of the pressure fits (``fitted_pressure``) ahead of each kernel's own
        fit_args = [h, n, nl.offsets, nl.indices, si.particle_q, m.particle_origin, sol.real_volume,
                    m.particle_material, pw.water, m.particle_ghost_source, m.particle_ghost_planes,
                    self.planes]  # fmt: skip
        if self.settings.stabilisation > 0.0 or self.settings.interior_stabilisation > 0.0:
            launch_rows(self.k["mark_near_surface"], n,
                        [n, nl.offsets, nl.indices, m.particle_ghost_source, rf.smallest_eigenvalue,
                         real(self.solver.config.free_surface_threshold), self.sealed_face, self.near_surface],
                        dev)  # fmt: skip
            launch_rows(self.k["roughness"], n,
                   [*fit_args, self.near_surface, int(self.damps_everywhere), self.dirichlet, self.p_old,
                    self.roughness], dev)  # fmt: skip
        launch_rows(self.k["assemble"], n,
               [h, real(dt), wp.float64(self.scale), n, nl.offsets, nl.indices, si.particle_q, m.particle_origin,
                sol.real_volume, si.particle_density, m.particle_material, pw.water, so.particle_v, self.div_v_star,
                self.p_old, m.particle_ghost_source, m.particle_ghost_planes, self.planes, self.dirichlet, self.value,
                self.face_factor, self.momentum_image, rf.smallest_eigenvalue,
                real(self.exterior_threshold), wp.float64(self.lattice_sum), self.roughness, self.near_surface,
                wp.float64(self.settings.stabilisation), wp.float64(self.settings.interior_stabilisation),
                self.weight, self.diag, self.rhs], dev)  # fmt: skip
        iterations, rel = self.linear.solve(self._matrix(), self.rhs, x)
        self.iterations.append(iterations)
        self.residuals.append(rel)
        if not rel <= self.settings.tolerance:
            self.failures += 1
            message = (f"pressure solve missed its tolerance {self.settings.tolerance:g}: relative residual "
                       f"{rel:.3g} after {iterations} iterations ({self.settings.solver}); raise "
                       f"pressure.max_iterations (now {self.settings.max_iterations})")  # fmt: skip
            if self.settings.on_failure == "stop":
                raise SimulationError(message)
            if self.failures == 1:
                warnings.warn(message + ', or set pressure.on_failure = "stop" to stop the run at such a miss '
                              "(further misses are counted in run.json)", stacklevel=2)  # fmt: skip
        if self.has_sealed_faces:
            launch_rows(self.k["extrapolate_to_sealed_faces"], n,
                        [*fit_args, self.sealed_face, 0, self.dirichlet, x, self.dp], dev)
            wp.copy(x, self.dp, count=n)
        # v = v* − (Δt/ρ) ∇(p − pⁿ), along the same path
        self.update_ghosts(si.particle_q, x, homogeneous=False)
        launch(self.k["difference"], m.particle_count, [0, x, self.p_old, self.dp], dev)
        self.update_ghosts(si.particle_q, self.dp, homogeneous=True, momentum=True)
        self._gradient(si, sol.real_volume, sol.virtual_volume, self.dp, homogeneous=True, momentum=True)
        launch(self.k["correct_velocity"], n, [0, real(dt), self.grad, so.particle_density, so.particle_v], dev)

    def free_surface_particles(self) -> np.ndarray:
        """Mask of the owned particles on a free surface (correction eigenvalue below
        DRAINED_SURFACE_EIGENVALUE at the last fit), drained planes' particles aside (host)."""
        n = self.model.particle_count
        eigenvalue = self.solver.real_fits.smallest_eigenvalue.numpy()[:n]
        return (eigenvalue < DRAINED_SURFACE_EIGENVALUE) & (self.on_drained.numpy()[:n] == 0)

    def check_reservoirs(self, si) -> None:
        """Refuse a reservoir whose region holds no free-surface particle: its water would do nothing."""
        m = self.model
        positions = si.particle_q.numpy()[: m.particle_count].astype(np.float64)
        wetted_regions(m.pore.reservoirs, positions, self.free_surface_particles(), m.dx)

    def _warn_unstable_free_surface(self, si, dt: float) -> None:
        """Warn once if the free surface found at the first step is less permeable than it can be
        stably: k ρ/Δt below the limit of its kind (``DAMPED_STABLE_SURFACE_RATIO`` with θ = 1, else
        ``STABLE_SURFACE_RATIO``) on one of its particles (a drained surface's Dirichlet rows, an
        impermeable one's particles that gain the exterior pairs)."""
        m = self.model
        n = m.particle_count
        kind = self.settings.free_surface
        limits = DAMPED_STABLE_SURFACE_RATIO if self.settings.stabilisation == 1.0 else STABLE_SURFACE_RATIO
        limit = limits[kind]
        if kind == "drained":
            surface = (self.dirichlet.numpy()[:n] == 1) & (self.on_drained.numpy()[:n] == 0)
        else:
            surface = self.solver.real_fits.smallest_eigenvalue.numpy()[:n] < self.exterior_threshold
        if not surface.any() or limit == 0.0:
            return
        material = m.particle_material.numpy()[:n][surface]
        ratio = m.pore.water.permeability.numpy()[material] * si.particle_density.numpy()[:n][surface] / dt
        worst = int(np.argmin(ratio))
        if ratio[worst] < limit:
            name = list(m.scene.materials)[material[worst]]
            courant = m.scene.simulation.courant * ratio[worst] / limit
            self.surface_warning = (
                f"material {name!r} under a free surface (pressure.free_surface = {kind!r}): k ρ/Δt = "
                f"{ratio[worst]:.3g} is below {limit}, where the pore pressure under such a surface can grow without "
                "bound (docs/method.md, Known limits); make that face a plane (a zero-traction load with its "
                f"drainage), lower simulation.courant to {courant:.2g}")
            warnings.warn(self.surface_warning, stacklevel=2)

    def _gradient(self, state, real_volume, virtual_volume, values, homogeneous: bool, momentum: bool = False) -> None:
        """``self.grad`` = ∇values at the real particles via the virtual points (geometry of ``state``, the
        points' volumes ``real_volume`` and ``virtual_volume``); ``values`` has its real ghosts set; virtual
        ghosts get the same parity."""
        m, sol = self.model, self.solver
        h, dev = m.spec.real(m.h), m.device
        rf, vf = sol.real_fits, sol.virtual_fits
        nl_v, nl_r = sol.virtual_to_real, sol.real_to_virtual
        launch_rows(self.k["fit_scalar_at_virtual"], m.virtual_count,
               [h, nl_v.offsets, nl_v.indices, state.virtual_q, vf.struct, state.particle_q, real_volume, values,
                self.virtual_dp], dev)  # fmt: skip
        self.update_ghosts(state.virtual_q, self.virtual_dp, homogeneous=homogeneous, virtual=True, momentum=momentum)
        launch_rows(self.k["gradient_at_real"], m.particle_count,
               [h, nl_r.offsets, nl_r.indices, state.particle_q, rf.struct, state.virtual_q, virtual_volume,
                self.virtual_dp, self.grad], dev)  # fmt: skip

    def darcy_velocity(self, state) -> np.ndarray:
        """(N,3) Darcy velocity w = −k ∇p [m/s] of ``state``, through the two-set path (host copy).

        Uses the neighbour lists and fit data of the step that produced ``state`` (its geometry
        differs from theirs by one step's motion)."""
        m = self.model
        self.update_ghosts(state.particle_q, state.particle_pore_pressure, homogeneous=False)
        real_volume = wp.empty(m.particle_total, dtype=m.spec.real, device=m.device)
        virtual_volume = wp.empty(m.virtual_total, dtype=m.spec.real, device=m.device)
        compute_volumes(m, m.particle_mass, state.particle_density, real_volume, 0, m.particle_total)
        compute_volumes(m, m.virtual_mass, state.virtual_density, virtual_volume, 0, m.virtual_total)
        self._gradient(state, real_volume, virtual_volume, state.particle_pore_pressure, homogeneous=False)
        w = wp.zeros(m.particle_count, dtype=wp.vec3d, device=m.device)
        launch(self.k["darcy"], m.particle_count,
               [self.grad, m.particle_material, m.pore.water, w], m.device)  # fmt: skip
        return w.numpy()

    def _matrix(self):
        """The assembled system on the real-real list, whose ghost neighbours stand for their sources."""
        m, nl = self.model, self.solver.real_to_real
        return sparse_rows(nl.offsets, self.weight, nl.indices, m.particle_ghost_source, self.diag, m.particle_count)
