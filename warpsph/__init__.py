"""warpsph: two-set Runge-Kutta Taylor SPH for saturated soils, on NVIDIA Warp.

The public API: describe a problem as a :class:`Scene` (or load one with :func:`load_scene`),
run it with :func:`run_scene` (or drive :func:`build` + :class:`Solver` yourself), and read the
output with :func:`load_results`.
"""

from warpsph.version import __version__

from warpsph.errors import InputError, SceneError, SimulationError
from warpsph.io import load_results
from warpsph.scene import (Body, Boundary, Effects, Load, Material, Output, Probe, Region, Scene, Simulation,
                           TimeFunction)  # fmt: skip
from warpsph.scene_toml import load_scene, parse_scene


def __getattr__(name):
    # Warp-dependent parts load on first use, so reading scenes and results stays light.
    if name == "build":
        from warpsph.builder import build

        return build
    if name == "Solver":
        from warpsph.solver import Solver

        return Solver
    if name in ("Run", "run_scene"):
        from warpsph import runner

        return getattr(runner, name)
    raise AttributeError(name)


def __dir__():
    return sorted(set(globals()) | set(__all__))


__all__ = ["Body", "Boundary", "Effects", "InputError", "Load", "Material", "Output", "Probe", "Region", "Run",
           "Scene", "SceneError", "Simulation", "SimulationError", "Solver", "TimeFunction", "build",
           "__version__", "load_results", "load_scene", "parse_scene", "run_scene"]  # fmt: skip
