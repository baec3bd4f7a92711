"""The PySPH side of ``python -m warpsph.bench --peer pysph`` (docs/performance.md, *Against PySPH*).

Run by the peer's own Python, so it imports PySPH and NumPy only:
``python peer_pysph.py --dim 2 --particles 16384 --steps 60 --threads 1`` prints one JSON line.
The block matches warpsph's benchmark block (lattice spacing 0.05 m, h = 1.3 Δx, cubic spline,
E = 30 MPa, ν = 0.2, ρ = 1700 kg/m³) on three rows of wall particles, moving in its first bending
mode. The scheme is PySPH's elastic-solid scheme of Gray, Monaghan & Swift (2001) (continuity,
momentum with stress, Monaghan artificial viscosity and stress, Hooke's rate with the Jaumann
terms, XSPH) with the EPEC integrator; in 3D the same equations with the 3D velocity gradient.
"""

import argparse
import json
import math
import os
import resource
import sys
import tempfile
import time

import numpy as np

DX, SMOOTHING_RATIO = 0.05, 1.3
DENSITY, YOUNGS_MODULUS, POISSON_RATIO = 1700.0, 30.0e6, 0.2
WALL_ROWS = 3
WARM_STEPS = 3
"""Steps left out of the steady-state figure (first-touch of the arrays, the caches)."""


def block_shape(n: int, dim: int) -> tuple:
    """Lattice points per axis of the near-square or near-cube block of about ``n`` points (as warpsph's)."""
    side = max(2, round(n ** (1.0 / dim)))
    height = max(2, round(n / side ** (dim - 1)))
    return (side, height) if dim == 2 else (side, height, side)


def lattice(shape: tuple, rows: range) -> list:
    """Coordinates [m] of the lattice points of ``shape`` whose y index is in ``rows``."""
    axes = [np.arange(shape[0]) * DX, np.array(list(rows)) * DX]
    if len(shape) == 3:
        axes.append(np.arange(shape[2]) * DX)
    return [a.ravel() for a in np.meshgrid(*axes, indexing="ij")]


def equations(dim: int, solid: str, wall: str):
    """The elastic-solid scheme's two groups, with the velocity gradient of ``dim``."""
    from pysph.sph.basic_equations import (ContinuityEquation, MonaghanArtificialViscosity, VelocityGradient2D,
                                           VelocityGradient3D, XSPHCorrection)
    from pysph.sph.equation import Group
    from pysph.sph.solid_mech.basic import (HookesDeviatoricStressRate, IsothermalEOS, MomentumEquationWithStress,
                                            MonaghanArtificialStress)

    sources = [solid, wall]
    gradient = VelocityGradient2D if dim == 2 else VelocityGradient3D
    return [
        Group(equations=[IsothermalEOS(solid, sources=None), gradient(dest=solid, sources=sources),
                         MonaghanArtificialStress(dest=solid, sources=None, eps=0.3)]),
        Group(equations=[ContinuityEquation(dest=solid, sources=sources),
                         MomentumEquationWithStress(dest=solid, sources=sources),
                         MonaghanArtificialViscosity(dest=solid, sources=sources, alpha=1.0, beta=1.0),
                         HookesDeviatoricStressRate(dest=solid, sources=None),
                         XSPHCorrection(dest=solid, sources=[solid], eps=0.5)]),
    ]


def make_application(dim: int, n: int, stamps: list):
    from pysph.base.kernels import CubicSpline
    from pysph.solver.application import Application
    from pysph.solver.solver import Solver
    from pysph.sph.integrator import EPECIntegrator
    from pysph.sph.integrator_step import SolidMechStep
    from pysph.sph.solid_mech.basic import get_particle_array_elastic_dynamics

    shape = block_shape(n, dim)
    h = SMOOTHING_RATIO * DX
    wave_speed = math.sqrt(YOUNGS_MODULUS / DENSITY)
    dt = 0.25 * h / wave_speed

    class Block(Application):
        def create_particles(self):
            kernel = CubicSpline(dim=dim)
            constants = dict(E=YOUNGS_MODULUS, nu=POISSON_RATIO, rho_ref=DENSITY, n=4,
                             wdeltap=kernel.kernel(rij=DX, h=h))
            mass = DENSITY * DX**dim
            coords = lattice(shape, range(shape[1]))
            x, y = coords[0], coords[1]
            z = coords[2] if dim == 3 else np.zeros_like(x)
            width = (shape[0] - 1) * DX
            v = 0.01 * wave_speed * np.sin(math.pi * x / width) * (y / ((shape[1] - 1) * DX))
            solid = get_particle_array_elastic_dynamics(x=x, y=y, z=z, v=v, m=mass, h=h, rho=DENSITY, name="solid",
                                                        constants=constants)
            wall_coords = lattice(shape, range(-WALL_ROWS, 0))
            wz = wall_coords[2] if dim == 3 else np.zeros_like(wall_coords[0])
            wall = get_particle_array_elastic_dynamics(x=wall_coords[0], y=wall_coords[1], z=wz, m=mass, h=h,
                                                       rho=DENSITY, name="wall", constants=constants)
            return [solid, wall]

        def create_equations(self):
            return equations(dim, "solid", "wall")

        def create_solver(self):
            integrator = EPECIntegrator(solid=SolidMechStep())
            return Solver(dim=dim, integrator=integrator, kernel=CubicSpline(dim=dim), dt=dt, tf=1e9)

        def post_step(self, solver):
            stamps.append(time.perf_counter())

    return Block, dt


def pair_count(app) -> int:
    """Solid–source neighbour pairs within 2h (each ordered pair once, self excluded) of the last
    neighbour search: the pairs one pass of a group's loop evaluates."""
    from cyarray.carray import UIntArray

    nnps = app.nnps
    nbrs = UIntArray()
    pairs = 0
    solid = [k for k, pa in enumerate(app.particles) if pa.name == "solid"][0]
    count = app.particles[solid].get_number_of_particles()
    for src in range(len(app.particles)):
        nnps.set_context(src, solid)
        for i in range(count):
            nnps.get_nearest_particles(src, solid, i, nbrs)
            pairs += nbrs.length - (1 if src == solid else 0)
    return pairs


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dim", type=int, choices=(2, 3), default=2)
    p.add_argument("--particles", type=int, default=16384)
    p.add_argument("--steps", type=int, default=60)
    p.add_argument("--threads", type=int, default=1, help="1: PySPH's serial build; more: OpenMP threads")
    args = p.parse_args(argv)
    os.environ["OMP_NUM_THREADS"] = str(args.threads)
    stamps = []
    Block, dt = make_application(args.dim, args.particles, stamps)
    with tempfile.TemporaryDirectory() as out:
        app = Block(fname="peer_block", output_dir=out)
        openmp = ["--openmp"] if args.threads > 1 else []
        app.setup(["--disable-output", "-d", out, "-q", "--max-steps", str(args.steps + WARM_STEPS), *openmp])
        app.solve()
        pairs = pair_count(app)
    import pysph

    particles = app.particles[0].get_number_of_particles()
    steady = len(stamps) - WARM_STEPS
    wall = stamps[-1] - stamps[WARM_STEPS - 1]
    arrays = sum(pa.get_carray(name).get_npy_array().nbytes for pa in app.particles for name in pa.properties)
    print(json.dumps({
        "peer": "pysph", "peer_version": pysph.__version__, "dim": args.dim, "threads": args.threads,
        "particles": particles, "wall_particles": app.particles[1].get_number_of_particles(), "steps": steady,
        "time_step": dt, "wall_seconds": wall, "particle_steps_per_second": particles * steady / wall,
        "neighbour_pairs_per_step": pairs, "neighbour_interactions_per_second": pairs * steady / wall,
        "array_bytes_per_particle": arrays / particles,
        "max_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
