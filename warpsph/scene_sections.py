"""The sections and items of a scene (:class:`~warpsph.scene.Scene`): plain dataclasses in SI units
that a TOML scene file and the Python API both produce (docs/scenes.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

AXES = ("x", "y", "z")
STANDARD_GRAVITY = 9.81
"""g [m/s²] converting hydraulic conductivity and heads to pressures."""


@dataclass
class TimeFunction:
    """Scalar factor f(t) multiplying a load.

    kind: "constant" (f = 1), "step" (0 before ``start``, 1 from it), "ramp" (0 before ``start``,
    linear to 1 over ``duration`` [s]) or "table" (piecewise linear through ``times`` [s] /
    ``values``, held constant outside).
    """

    kind: str = "constant"
    start: float = 0.0
    duration: float = 0.0
    times: list[float] = field(default_factory=list)
    values: list[float] = field(default_factory=list)

    def __call__(self, t: float) -> float:
        if self.kind == "constant":
            return 1.0
        if self.kind == "step":
            return 1.0 if t >= self.start else 0.0
        if self.kind == "ramp":
            if t < self.start:
                return 0.0
            if self.duration <= 0.0:
                return 1.0
            return min(1.0, (t - self.start) / self.duration)
        if self.kind == "table":
            return float(np.interp(t, self.times, self.values))
        raise ValueError(f"unknown time function kind {self.kind!r}")


EXTENT_TOLERANCE = 1.0e-6
"""Load and drainage extents are grown by this fraction of Δx: a point on an edge is inside."""


@dataclass
class Region:
    """Axis-aligned box [min, max] in metres; unused coordinates may be left at 0."""

    min: tuple[float, float, float] = (-math.inf, -math.inf, -math.inf)
    max: tuple[float, float, float] = (math.inf, math.inf, math.inf)

    def contains(self, points: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """Boolean mask of the (N,3) ``points`` inside the box, grown by ``tol`` [m]."""
        lo = np.asarray(self.min, dtype=float) - tol
        hi = np.asarray(self.max, dtype=float) + tol
        return np.all((points >= lo) & (points <= hi), axis=1)

    def contains_on_face(self, points: np.ndarray, axis: int, tol: float = 0.0) -> np.ndarray:
        """Mask of the (N,3) ``points`` inside the box grown by ``tol`` [m], coordinate ``axis`` aside
        (a face's extent)."""
        others = [k for k in range(3) if k != axis]
        lo = np.asarray(self.min, dtype=float)[others] - tol
        hi = np.asarray(self.max, dtype=float)[others] + tol
        return np.all((points[:, others] >= lo) & (points[:, others] <= hi), axis=1)


@dataclass
class Simulation:
    """Discretisation and time integration settings."""

    dim: int = 2
    """Spatial dimension: 1 (a column along y), 2 (plane strain in x-y) or 3."""
    dx: float = 0.1
    """Initial particle spacing Δx [m]."""
    end_time: float = 1.0
    """Simulated time at which the run stops [s]."""
    smoothing_ratio: float = 1.3
    """Smoothing length over spacing, h/Δx (accepted 1.1 to 2.0)."""
    kernel: str = "cubic_spline"
    """Smoothing kernel: "cubic_spline" or "wendland_c2" (both with support 2h)."""
    scheme: str = "two_set"
    """"two_set" (Taylor-SPH with virtual stress points) or "collocated" (one set, method of lines)."""
    integrator: str = "rk4"
    """Runge-Kutta integrator for sources (two_set) or the whole system (collocated): "rk2" or "rk4"."""
    courant: float = 0.5
    """Courant number C in Δt = C Δx / c_p."""
    gravity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Body force per unit mass [m/s²]; y is up, so gravity is usually (0, -9.81, 0)."""
    precision: str = "float64"
    """Floating-point type of the particle fields: "float64" or "float32"."""
    artificial_viscosity: float = 0.0
    """Monaghan artificial viscosity coefficient α (0 disables it), in both schemes."""
    stress_filter: float = 0.0
    """Two-set scheme: fraction β [-] of the real particles' stress that the virtual points do not see
    (an odd-even stress mode) removed each step (0 disables it; docs/method.md, "Stress filter")."""
    velocity_filter: float = 0.0
    """Two-set scheme: fraction β [-] of the real particles' velocity that the virtual points do not see
    (their own mid-step velocity against the one fitted at them, which moves them) removed each step
    (0 disables it; docs/method.md, "Velocity filter")."""
    hourglass_control: float = 0.0
    """Two-set scheme: coefficient α [-] of the hourglass control, the pairwise damping of the real
    particles' velocity that their own linear fit does not hold, with the viscosity α ρ c h (0 disables
    it; docs/method.md, "Hourglass control")."""
    velocity_limit: float | None = None
    """Run guard: the run stops if a particle moves faster than this [m/s]; None: the largest P-wave
    speed of the scene's materials (``inf`` turns the bound off)."""
    free_surface_threshold: float = 0.75
    """Points whose smallest correction-matrix eigenvalue is below this form the free-surface band."""
    large_deformation: bool = False
    """Re-plan the mirror ghosts from the current positions whenever a point has moved farther than
    the ghost margin since the last plan (flows, collapses); off, the start's layout is kept. On, the
    surface band's traction term is not divided by the particles' shares (docs/method.md)."""
    virtual_points: str = "advected"
    """Large deformation: "advected" (virtual points move with their half-step velocity) or
    "regenerated" (rebuilt on the start's lattice from the real particles at every ghost re-plan)."""
    particle_velocity: str = "fitted"
    """Two-set scheme: the velocity that moves the real particles, "fitted" (v^{n+½} fitted from the
    virtual points) or "own" (the particle's own, (vⁿ + vⁿ⁺¹)/2; docs/method.md, "Large deformation")."""
    virtual_density: str = "integrated"
    """Two-set scheme: how a virtual point's density advances, "integrated" (continuity with the
    divergence of the real particles' velocities fitted at it) or "real_motion" (continuity with the
    rate of deformation of the real particles' motion over the step, fitted at it: the point keeps the
    density of the reals around it; docs/method.md, "Virtual densities")."""
    particle_shifting: float = 0.0
    """Large deformation, two-set scheme: particle-shifting coefficient A [-] (0 disables it). Each
    point set is shifted by −A h² Δt‖d‖ ∇C down the gradient of its own concentration C (docs/method.md,
    "Large deformation")."""


@dataclass(frozen=True)
class Effects:
    """Physical effects a scene switches on; decides stages, compiled kernels and allocated arrays."""

    pore_water: bool = False
    """Saturated soil with pore-water pressure (v-pw model with pressure projection)."""
    plasticity: bool = False
    """Perzyna viscoplasticity."""


@dataclass
class Material:
    """Linear hypo-elastic solid (Jaumann rate); with ``model = "viscoplastic"`` (plasticity effect)
    also Perzyna viscoplastic over one of three yield functions (docs/scenes.md, docs/method.md)."""

    name: str = "material"
    model: str = "elastic"
    """"elastic" or "viscoplastic" (needs effects.plasticity)."""
    density: float = 2000.0
    """Mass density ρ [kg/m³]."""
    youngs_modulus: float = 1.0e7
    """Young's modulus E [Pa]."""
    poisson_ratio: float = 0.3
    """Poisson's ratio ν [-], in (-1, 0.5)."""
    porosity: float = 0.3
    """Porosity n [-] in (0, 1) (pore_water effect)."""
    grain_density: float | None = None
    """Grain density ρ_s [kg/m³]; when given, ``density`` is the saturated mixture (1−n)ρ_s + nρ_w."""
    water_density: float = 1000.0
    """Pore-water density ρ_w [kg/m³] (pore_water effect)."""
    grain_bulk_modulus: float = math.inf
    """Grain bulk modulus K_s [Pa]; inf for rigid grains (pore_water effect)."""
    water_bulk_modulus: float = 2.2e9
    """Water bulk modulus K_w [Pa]; inf for incompressible water (pore_water effect)."""
    hydraulic_conductivity: float = 1.0e-5
    """Hydraulic conductivity k_h [m/s] ≥ 0; k = k_h / (ρ_w g) with g = 9.81 m/s² (pore_water effect)."""
    k0: float | None = None
    """Earth-pressure coefficient at rest for geostatic stresses; None means ν/(1−ν)."""
    yield_function: str = "von_mises"
    """"von_mises", "drucker_prager" (matched to Mohr–Coulomb in plane strain) or "mohr_coulomb"
    (rounded corners); one per scene (viscoplastic)."""
    cohesion: float = 0.0
    """Cohesion c [Pa] ≥ 0; for von Mises the undrained shear strength c_u, σ_Y = √3 c (viscoplastic)."""
    friction_angle: float = 0.0
    """Friction angle φ [degrees] in [0, 90) (Drucker–Prager, Mohr–Coulomb)."""
    dilatancy_angle: float = 0.0
    """Dilatancy angle ψ [degrees] in [0, φ]; ψ = φ is associated flow (Drucker–Prager, Mohr–Coulomb)."""
    hardening_modulus: float = 0.0
    """H = dc/dε̄ [Pa] per unit equivalent plastic strain; < 0 softens (viscoplastic)."""
    residual_cohesion: float = 0.0
    """Floor c_r [Pa] in [0, cohesion] of the softened cohesion c + H ε̄ (viscoplastic)."""
    fluidity: float = 1.0
    """Perzyna fluidity γ [1/s] > 0 (viscoplastic)."""
    reference_stress: float = 1.0e4
    """Perzyna normalising stress F₀ [Pa] > 0: d^vp = γ ⟨F/F₀⟩^N ∂G/∂σ′ (viscoplastic)."""
    rate_exponent: float = 1.0
    """Perzyna exponent N ≥ 1 (viscoplastic)."""
    retention: str = "saturated"
    """Water retention above the phreatic surface (pore_water effect, flow phases): "saturated" (S = 1
    at any suction), "van_genuchten" (van Genuchten–Mualem) or "gardner" (exponential); docs/scenes.md,
    *Groundwater flow*."""
    retention_alpha: float = 1.0
    """α [1/m]: the inverse of the suction head at which the soil starts to desaturate (van Genuchten),
    or the exponent of S_e = k_r = exp(−α ψ) (Gardner)."""
    retention_n: float = 2.0
    """van Genuchten n > 1 [-] (m = 1 − 1/n); larger n desaturates more sharply."""
    residual_saturation: float = 0.0
    """Residual degree of saturation S_r in [0, 1) [-]: S = S_r + (1 − S_r) S_e."""

    @property
    def shear_modulus(self) -> float:
        """G [Pa]."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def lame_lambda(self) -> float:
        """λ [Pa]."""
        nu = self.poisson_ratio
        return self.youngs_modulus * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))

    @property
    def bulk_modulus(self) -> float:
        """K [Pa]."""
        return self.youngs_modulus / (3.0 * (1.0 - 2.0 * self.poisson_ratio))

    @property
    def oedometric_modulus(self) -> float:
        """E_oed = K + 4G/3 [Pa]."""
        return self.lame_lambda + 2.0 * self.shear_modulus

    @property
    def biot_modulus(self) -> float:
        """Q [Pa], 1/Q = (1−n)/K_s + n/K_w (inf when both constituents are incompressible)."""
        inv = (1.0 - self.porosity) / self.grain_bulk_modulus + self.porosity / self.water_bulk_modulus
        return math.inf if inv == 0.0 else 1.0 / inv

    @property
    def permeability(self) -> float:
        """k = k_h / (ρ_w g) [m³·s/kg], with the standard g = 9.81 m/s²."""
        return self.hydraulic_conductivity / (self.water_density * STANDARD_GRAVITY)

    @property
    def earth_pressure_at_rest(self) -> float:
        """K0 [-]: ``k0`` or ν/(1−ν)."""
        return self.k0 if self.k0 is not None else self.poisson_ratio / (1.0 - self.poisson_ratio)

    @property
    def p_wave_speed(self) -> float:
        """Drained P-wave speed √(E_oed/ρ) [m/s]."""
        return math.sqrt(self.oedometric_modulus / self.density)


@dataclass
class Body:
    """A region filled with particles on a lattice of spacing Δx.

    shape: "box" (``min``/``max`` corners [m]), "polygon" (2D only, ``vertices`` as [[x, y], ...] in m)
    or "circle" (``center`` [m], ``radius`` [m]; a disc in 2D, a sphere in 3D, a segment in 1D).
    """

    name: str = "body"
    material: str = "material"
    shape: str = "box"
    min: tuple[float, float, float] = (0.0, 0.0, 0.0)
    max: tuple[float, float, float] = (1.0, 1.0, 1.0)
    vertices: list[tuple[float, float]] = field(default_factory=list)
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.0
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Initial velocity [m/s]."""
    angular_velocity: float = 0.0
    """Initial rigid spin about the z axis through ``center`` [rad/s] (2D and 3D)."""
    stress: tuple[float, float, float, float, float, float] = (0.0,) * 6
    """Initial effective stress, Voigt order xx, yy, zz, yz, xz, xy [Pa, tension positive]."""
    pore_pressure: float = 0.0
    """Initial excess pore pressure over the hydrostatic one [Pa, compression positive] (pore_water)."""
    geostatic: bool = False
    """Add geostatic effective stresses under gravity: σ′_yy = −(ρ − ρ_w) g (top − y), the top the body's
    highest particle in the particle's own column, σ′_xx = σ′_zz = K0 σ′_yy (ρ_w = 0 without pore
    water)."""
    embedded: bool = False
    """The body lies inside bodies listed after it and takes the lattice points it shares with them
    (an inclusion, a weaker seed); without it, bodies that overlap are an error."""


@dataclass
class Drainage:
    """Pore-water condition of a plane (pore_water effect).

    kind: "impermeable" (w·n = 0), "drained" (pore pressure ``pore_pressure`` [Pa] or, when
    ``head`` [m] is given, ρ_w g (head − y)) or "inflow" (water enters at ``inflow`` [m/s], the
    Darcy velocity into the body). Where ``extent`` is given, the face drains (or takes its inflow)
    only inside that box, measured along the face, and is impermeable elsewhere: an impermeable
    footing on a drained ground surface.
    """

    kind: str = "impermeable"
    pore_pressure: float = 0.0
    head: float | None = None
    inflow: float = 0.0
    extent: Region | None = None
    time_function: TimeFunction = field(default_factory=TimeFunction)
    """The pore pressure, head and inflow are multiplied by f(t) of the phase's time, in every phase
    kind (a head table of a rising river is ``head`` = its highest level with values ≤ 1)."""

    def covers(self, points: np.ndarray, axis: int, tol: float = 0.0) -> np.ndarray:
        """Mask of the (N,3) ``points`` of a face normal to ``axis`` where this condition holds (its
        extent grown by ``tol`` [m])."""
        if self.extent is None:
            return np.ones(len(points), dtype=bool)
        return self.extent.contains_on_face(points, axis, tol)


class _OnPlane:
    """Shared by the plane-based records: ``axis`` ("x"|"y"|"z") and ``side`` ("min"|"max")."""

    axis: str
    side: str

    @property
    def axis_index(self) -> int:
        return AXES.index(self.axis)

    @property
    def outward_sign(self) -> float:
        """+1 if the outward normal points along +axis (side "max"), −1 otherwise."""
        return 1.0 if self.side == "max" else -1.0


@dataclass
class Boundary(_OnPlane):
    """A planar boundary perpendicular to an axis, closed by mirror ghost particles.

    kind: "fixed" (v = 0), "slip" (v·n = 0, no shear traction), "symmetry" (same as slip),
    "free" (traction-free face) or "velocity" (v = ``velocity`` × f(t)).
    The plane is ``axis`` = ``position`` [m]; ``side`` "min" means the body lies on the
    positive side of the plane (outward normal −axis), "max" the negative side.
    """

    name: str = "boundary"
    kind: str = "fixed"
    axis: str = "y"
    position: float = 0.0
    side: str = "min"
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    time_function: TimeFunction = field(default_factory=TimeFunction)
    drainage: Drainage = field(default_factory=Drainage)
    """Pore-water condition of the plane (pore_water effect)."""
    friction_angle: float = 0.0
    """A "slip" plane of a large-deformation scene: Coulomb friction angle [deg] between the plane
    and the particles lying on it (0: frictionless; docs/method.md, "Large deformation")."""


@dataclass
class Load(_OnPlane):
    """A prescribed traction on a planar face or a prescribed velocity of a region.

    kind "traction": the face ``axis`` = ``position`` on ``side`` (as for :class:`Boundary`)
    carries traction t = σ·n = ``traction`` × f(t) [Pa] (n outward, so a compressive load on a top
    face is (0, −p, 0)); where ``extent`` is given, the face outside it is traction-free.
    kind "velocity": every particle and virtual point that starts inside ``region`` moves at
    ``velocity`` × f(t) [m/s] (a rigid piston or footing; make it thicker than the support 2h).
    kind "force": those points move as one rigid body in translation under ``force`` × f(t)
    [N/m in 2D, N in 3D], gravity and the rest of the body (a footing under a load).
    kind "plate": a rigid plate (a footing) on the face ``axis`` = ``position`` on ``side``, over ``extent``
    along it (none: the whole face), the rest of the face traction-free. ``drive`` "velocity" moves it at
    ``velocity`` × f(t); "force" moves it so that it passes ``force`` × f(t) [N/m in 2D, N in 3D] into
    the soil. ``contact`` "rough" holds the particles under it to its motion, "smooth" along its normal
    only; its base is ``base_drainage`` ("impermeable" or "drained", pore water), its face beside it
    ``drainage``. It translates, and with ``rotation`` "free" spins too (docs/method.md, *Rigid plates*).
    """

    name: str = "load"
    kind: str = "traction"
    axis: str = "y"
    position: float = 0.0
    side: str = "max"
    traction: tuple[float, float, float] = (0.0, 0.0, 0.0)
    extent: Region | None = None
    region: Region | None = None
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    force: tuple[float, float, float] = (0.0, 0.0, 0.0)
    contact: str = "rough"
    """Rigid loads: "rough" (the region moves rigidly) or "smooth" (only along the drive direction;
    across it the region's points move freely, so the contact carries no friction)."""
    drive: str = "force"
    """A plate: "force" or "velocity"."""
    base_drainage: str = "impermeable"
    """A plate's base: "impermeable" or "drained" (pore water)."""
    rotation: str = "fixed"
    """A plate: "fixed" (it translates) or "free" (it also spins about its centre, in 2D about z, in 3D about
    the axes along its face, under ``moment`` × f(t) and the soil's moment)."""
    moment: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """A plate free to rotate: the moment applied about its centre [N m/m in 2D, N m in 3D]."""
    time_function: TimeFunction = field(default_factory=TimeFunction)
    drainage: Drainage = field(default_factory=Drainage)
    """Pore-water condition of the loaded face (pore_water effect)."""


@dataclass
class Reservoir:
    """A body of free water standing against the model's free surfaces (pore_water effect).

    The free-surface particles inside ``region`` and below the water's level y = ``level`` × f(t) [m]
    take its pore pressure ρ_w g (level − y) and, in mechanical phases, carry it as a total traction;
    in flow phases every other free-surface particle is a seepage face, where water leaves once its
    pore pressure would exceed the atmosphere's and none enters (docs/scenes.md, *Groundwater flow*).
    """

    name: str = "reservoir"
    level: float = 0.0
    region: Region = field(default_factory=Region)
    time_function: TimeFunction = field(default_factory=TimeFunction)


@dataclass
class Probe:
    """A time series written to the results file.

    kind "point": ``field`` at the material particle nearest ``point``; "region_mean": mean of
    ``field`` over the particles inside ``region``; "maximum" / "minimum": the largest / smallest
    value of ``field`` over the particles inside ``region`` (all particles without one), e.g. the
    front of a flow as the maximum of position_x; "reaction": force per unit out-of-plane length
    (2D) or force (3D) [N/m or N] that the boundary or load named ``boundary`` exerts on the body,
    component ``field`` ("x", "y" or "z"); for a "velocity" or "force" load, the contact force its
    rigid region exerts on the rest of the body.
    Fields: velocity_x|y|z [m/s], position_x|y|z [m], displacement_x|y|z [m], stress_xx|yy|zz|yz|xz|xy [Pa],
    mean_stress [Pa], von_mises [Pa], pore_pressure [Pa] (total; pore_water only), plastic_strain
    [-] (plasticity only). The written value is the probe's value times ``scale`` (e.g. a reaction
    over a loaded width gives a mean pressure, or −1 turns tension-positive into compression-positive).
    """

    name: str = "probe"
    kind: str = "point"
    field: str = "stress_yy"
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    region: Region | None = None
    boundary: str = ""
    scale: float = 1.0


@dataclass
class PressureSolver:
    """The pore-pressure projection (pore_water effect)."""

    solver: str = "cg"
    """"cg" (Jacobi-preconditioned conjugate gradients) or "jacobi" (weighted Jacobi)."""
    tolerance: float = 1.0e-8
    """Relative residual ‖b − Ax‖/‖b‖ at which a solve stops [-]."""
    max_iterations: int = 1000
    """Iteration cap of a solve."""
    jacobi_weight: float = 0.8
    """Relaxation weight ω of weighted Jacobi, in (0, 1]."""
    on_failure: str = "warn"
    """A solve that misses its tolerance: "warn" (once per run, and counted) or "stop"."""
    water_table: float | None = None
    """Level y [m] of the hydrostatic reference, p = ρ_w g (water_table − y); None: the top of the bodies."""
    free_surface: str = "drained"
    """Free surfaces found from the particles: "drained" (p = 0) or "impermeable"."""
    suction: str = "ignored"
    """Pore pressures below zero where equilibrium and safety phases hold them and in the K0 procedure:
    "ignored" (the total stress carries max(p_w, 0), as Bishop's method and SLOPE/W take them) or
    "counted" (Bishop's χ p_w, χ = S_e). A consolidation phase's held iterates always count them."""
    stabilisation: float = 1.0
    """Weight θ in [0, 1] of the pore-pressure roughness damping within reach of a free surface: there
    the Δt/ρ part of the projection acts on pⁿ − θ(pⁿ − Πpⁿ), Πp the linear fit of p over the
    neighbours off drained rows, which removes the odd-even part that nothing else damps at low
    permeability; 0 turns it off."""
    interior_stabilisation: float = 0.0
    """The same weight everywhere else (away from free surfaces): small values (0.02–0.05) keep
    plane-bounded 2D domains stable at low permeability, at the cost of smearing the pressure's
    boundary layers at drained and loaded faces over a few rows (docs/method.md)."""


@dataclass
class Output:
    """What is written and how often."""

    frame_interval: float = 0.01
    """Simulated time between frames [s]."""
    fields: list[str] = field(default_factory=lambda: ["velocity", "stress"])
    """Per-particle fields written in frames besides position."""
    usd: bool = True
    """Write a USD particle cache (``particles.usdc``)."""
    xdmf: bool = True
    """Write an XDMF sidecar for ParaView."""
    checkpoint_interval: float = 0.0
    """Simulated time between checkpoints [s]; 0 writes one checkpoint per frame."""
    probe_every: int = 1
    """Probes are sampled every this many steps."""


PHASE_KINDS = ("k0", "equilibrium", "safety", "dynamic", "flow", "consolidation")
"""Kinds of :class:`Phase` (docs/scenes.md, *Phases*)."""
IMPLICIT_PHASE_KINDS = ("flow", "consolidation")
"""Kinds of :class:`Phase` that advance the pore water in implicit steps sized by accuracy."""
FAILURE_DISPLACEMENT = 0.02
"""A safety trial's default failure displacement as a fraction of the bodies' height [-]. Measured on
Griffiths & Lane's slope (12 m of soil), the largest displacement of trials that come to rest: at
Δx = 1 m 0.10, 0.18 and 0.22 m at F = 1.375, 1.406 and 1.422, then 0.47 m at 1.4375 and 0.78 m at
1.5; at Δx = 0.5 m 0.02 m at 1.375 and 0.35 m at 1.4375 (docs/scenes.md, *Phases*)."""


@dataclass
class Phase:
    """One stage of a staged analysis; the scene's phases run in order, each from the state the one
    before left (docs/scenes.md, *Phases*).

    kind "k0": geostatic stresses set at once (the K0 procedure for horizontal ground: σ′_v from the
    weight of the soil above each particle, σ′_h = K0 σ′_v); "equilibrium": static equilibrium
    under gravity and the phase's loads, reached by dynamics with local damping, ended when the
    unbalanced-force ratio falls below ``tolerance``; "safety": the factor of safety by strength
    reduction, each trial an equilibrium from the phase's start with the strengths divided by the
    trial factor; "dynamic": the unmodified solver for ``duration`` [s] (or until the mass is at rest);
    "flow": groundwater flow through the fixed skeleton in implicit steps, a transient of ``duration``
    [s] or the ``steady`` state, with seepage faces and reservoirs (docs/scenes.md, *Groundwater flow*);
    "consolidation": the coupled quasi-static transient of ``duration`` [s] in the flow's implicit steps,
    the skeleton brought to equilibrium (as in "equilibrium") under each step's pore pressures
    (docs/scenes.md, *Consolidation*).
    """

    name: str = "phase"
    kind: str = "dynamic"
    duration: float = 0.0
    """Dynamic: simulated time the phase lasts [s] (> 0)."""
    tolerance: float = 1.0e-5
    """Equilibrium and safety: the unbalanced-force ratio at which equilibrium is reached [-]; flow: the
    largest pressure change of an iteration, over ρ_w g times the bodies' height, at which the
    pressure iteration of a step (or of the steady state) has converged [-]; consolidation: both."""
    max_steps: int = 20000
    """Equilibrium: the step cap (a phase that reaches it has not converged); safety: the cap of each
    trial (one collapsing there fails, one still slowing down is extended, twice at most); consolidation:
    the cap of each equilibrium of the skeleton (a phase whose skeleton does not reach equilibrium within
    it ends not converged); dynamic and flow: a cap on the phase's steps too (a steady flow phase's
    pressure iterations)."""
    damping: float = 0.8
    """Equilibrium, safety and consolidation: the local damping coefficient α in [0, 1) [-]."""
    at_rest: float = 0.0
    """Dynamic: end the phase once the kinetic energy has fallen below this fraction of its peak in
    the phase [-] (0: run the whole duration)."""
    activate: list[str] = field(default_factory=list)
    """Bodies, loads and boundaries switched on at the start of this phase; an item that some
    phase activates is off before it."""
    deactivate: list[str] = field(default_factory=list)
    """Bodies (excavation), loads and boundaries switched off at the start of this phase."""
    changes: dict[str, object] = field(default_factory=dict)
    """Scene keys set from this phase on, by their key paths: ``"bodies.dyke.material" = "clay"``,
    ``"loads.top.traction" = [0, -2e4]``, ``"materials.soil.cohesion" = 5e3``."""
    reset_displacements: bool = False
    """Measure displacements from the positions at the start of this phase."""
    pore_pressure: str = "coupled"
    """Equilibrium, safety and dynamic with pore water: "coupled" (the pore pressure follows the
    deformation and the flow, the projection) or "fixed" (held at the phase's start, as a drained
    analysis under the seepage of a flow phase before; the total stress carries Bishop's χ p_w)."""
    steady: bool = False
    """Flow: solve for the steady state instead of a transient of ``duration``."""
    time_step: float = 0.0
    """Flow and consolidation: the first implicit time step [s]; 0: ``duration`` / 1000. Later steps grow while the
    pressure iteration converges quickly and shrink where it does not."""
    frames: int = 10
    """Flow and consolidation: frames written over the phase, evenly in time (a steady phase writes its
    end)."""
    factor_tolerance: float = 0.01
    """Safety: the search stops when the factor of safety is bracketed to ± this [-]."""
    factor_max: float = 10.0
    """Safety: the largest trial factor [-]; a body that stands at it has a factor of safety above it."""
    failure_displacement: float = 0.0
    """Safety: a trial also fails once a particle has moved more than this [m] from the trial's start
    (a mechanism has formed); 0: ``FAILURE_DISPLACEMENT`` times the active bodies' height (their
    extent along gravity, or their largest extent without it)."""
    min_failing_mass: float = 8.0
    """Safety: the phase warns when its failing mass is fewer particle spacings high than this [-] (≥ 1):
    the factor of safety is then not converged in the spacing."""
    incremental: bool = False
    """Safety: each trial starts from the state of the strongest trial that stood below it (incremental
    reduction, as PLAXIS's: fewer steps, a factor that depends on the trials before it); false: every trial
    from the phase's start (as FLAC's)."""
    slip_region: Region = field(default_factory=Region)
    """Safety: where the limit-equilibrium search looks [m]: a slip circle's sliding mass lies between its
    min and max x and its arc no lower than its min y (SLOPE/W's entry and exit ranges; default: the whole
    ground). Strength reduction finds its own mechanism anywhere."""
    refine: bool = False
    """Safety: also run the search at half the particle spacing (the scene's phases up to this one, rebuilt
    at Δx/2 in ``RUN_DIR/refined_NAME``) and report both factors and their difference."""
