"""Scene description: the plain dataclasses that a TOML scene file and the Python API both produce.

Everything here is host-side data in SI units; :mod:`warpsph.builder` turns a :class:`Scene`
into device arrays. ``Scene.validate()`` checks physical sanity and cross references and raises
:class:`warpsph.errors.SceneError` naming the offending key path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

AXES = ("x", "y", "z")


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
    velocity_limit: float = math.inf
    """Run guard: the run stops if any particle speed exceeds this [m/s]."""
    free_surface_threshold: float = 0.75
    """Points whose smallest correction-matrix eigenvalue is below this form the free-surface band."""


@dataclass(frozen=True)
class Effects:
    """Physical effects a scene switches on; decides stages, compiled kernels and allocated arrays."""

    pore_water: bool = False
    """Saturated soil with pore-water pressure (v-pw model with pressure projection)."""
    plasticity: bool = False
    """Perzyna viscoplasticity."""


@dataclass
class Material:
    """Linear hypo-elastic solid (Jaumann rate)."""

    name: str = "material"
    model: str = "elastic"
    density: float = 2000.0
    """Mass density ρ [kg/m³]."""
    youngs_modulus: float = 1.0e7
    """Young's modulus E [Pa]."""
    poisson_ratio: float = 0.3
    """Poisson's ratio ν [-], in (-1, 0.5)."""

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
    def p_wave_speed(self) -> float:
        """Drained P-wave speed √(E_oed/ρ) [m/s]."""
        return math.sqrt(self.oedometric_modulus / self.density)


@dataclass
class Body:
    """A region filled with particles on a lattice of spacing Δx.

    shape: "box" (``min``/``max`` corners [m]), "polygon" (2D only, ``vertices`` [[x, y], ...] [m])
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


@dataclass
class Load(_OnPlane):
    """A prescribed traction on a planar face or a prescribed velocity of a region.

    kind "traction": the face ``axis`` = ``position`` on ``side`` (as for :class:`Boundary`)
    carries traction t = σ·n = ``traction`` × f(t) [Pa] (n outward, so a compressive load on a top
    face is (0, −p, 0)); where ``extent`` is given, the face outside it is traction-free.
    kind "velocity": every particle and virtual point that starts inside ``region`` moves at
    ``velocity`` × f(t) [m/s] (a rigid piston; make it thicker than the support 2h).
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
    time_function: TimeFunction = field(default_factory=TimeFunction)


@dataclass
class Probe:
    """A time series written to the results file.

    kind "point": ``field`` at the material particle nearest ``point``; "region_mean": mean of
    ``field`` over the particles inside ``region``; "reaction": force per unit out-of-plane length
    (2D) or force (3D) [N/m or N] that the boundary or load named ``boundary`` exerts on the body,
    component ``field`` ("x", "y" or "z").
    Fields: velocity_x|y|z [m/s], displacement_x|y|z [m], stress_xx|yy|zz|yz|xz|xy [Pa],
    mean_stress [Pa], von_mises [Pa].
    """

    name: str = "probe"
    kind: str = "point"
    field: str = "stress_yy"
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    region: Region | None = None
    boundary: str = ""


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


@dataclass
class Scene:
    """A complete simulation set-up."""

    name: str = "scene"
    simulation: Simulation = field(default_factory=Simulation)
    effects: Effects = field(default_factory=Effects)
    materials: dict[str, Material] = field(default_factory=dict)
    bodies: list[Body] = field(default_factory=list)
    boundaries: list[Boundary] = field(default_factory=list)
    loads: list[Load] = field(default_factory=list)
    probes: list[Probe] = field(default_factory=list)
    output: Output = field(default_factory=Output)
    source_text: str = ""
    """The scene file's text, stored in results for provenance (empty for Python-built scenes)."""

    @property
    def smoothing_length(self) -> float:
        """h [m]."""
        return self.simulation.smoothing_ratio * self.simulation.dx

    @property
    def max_p_wave_speed(self) -> float:
        """Largest drained P-wave speed of the materials in use [m/s]."""
        used = {b.material for b in self.bodies}
        return max(self.materials[m].p_wave_speed for m in used)

    @property
    def time_step(self) -> float:
        """Δt = C Δx / c_p [s]."""
        return self.simulation.courant * self.simulation.dx / self.max_p_wave_speed

    def validate(self) -> "Scene":
        """Check the scene; raise :class:`warpsph.errors.SceneError` naming the key path."""
        from warpsph.validation import validate_scene

        validate_scene(self)
        return self
