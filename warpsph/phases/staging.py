"""The scene each phase runs and the record of what it did (docs/scenes.md, *Phases*): a phase's scene
is the scene's own with the ``changes`` of that phase and of every phase before it applied, and only
the bodies, loads and boundaries active in it."""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from warpsph.errors import SceneError
from warpsph.scene_sections import Phase

if TYPE_CHECKING:
    from warpsph.scene import Scene

SWITCHED = ("bodies", "loads", "boundaries")
"""The sections whose items a phase activates or deactivates by name."""
CONVERGED, NOT_CONVERGED, FINISHED, AT_REST, STOPPED, UNSTABLE = ("converged", "not converged", "finished", "at rest",
                                                                   "stopped", "unstable")  # fmt: skip
"""A phase's outcome: an equilibrium that reached its criterion or its step cap; a dynamic phase that
ran its duration or came to rest; a phase cut short by ``--end-time`` or a signal; a phase the run
guard stopped."""


@dataclass
class PhaseRecord:
    """What a phase did, as written to ``/phases`` of the results and kept in checkpoints."""

    name: str
    kind: str
    first_step: int
    start_time: float
    last_step: int = -1
    end_time: float = 0.0
    outcome: str = ""
    criterion: float = float("nan")
    """The criterion reached: the final unbalanced-force ratio (equilibrium), the factor of safety
    (safety) or the final over peak kinetic energy (dynamic with ``at_rest``)."""
    resolution: float = float("nan")
    """Safety: the factor of safety's ± (half the final bracket's width)."""
    failing_mass: float = float("nan")
    """Safety: the height of the weakest failing trial's mechanism in particle spacings (its particles
    that moved more than half as far as the farthest 1 %, their extent along gravity, plus one spacing)."""
    refined: list = field(default_factory=list)
    """Safety with ``refine``: [the factor of safety, its resolution] of the same search at half the
    particle spacing (nan where that search did not bracket it)."""
    limit_equilibrium: list = field(default_factory=list)
    """Safety: limit equilibrium at the phase's start, [Bishop's factor, Spencer's, the critical circle's
    centre x, y and radius [m], Bishop's with the arcs kept above the rows of particles that do not shear] (nan
    where not found; :mod:`~warpsph.phases.limit_equilibrium`)."""
    trials: list = field(default_factory=list)
    """Safety: one row per trial (:attr:`~warpsph.phases.safety.TrialOutcome.row`)."""


def default_phases(scene: Scene) -> list[Phase]:
    """The scene's phases; without any, one dynamic phase to ``simulation.end_time``."""
    if scene.phases:
        return list(scene.phases)
    return [Phase(name="dynamic", kind="dynamic", duration=scene.simulation.end_time, max_steps=2**62)]


def active_items(scene: Scene, index: int) -> dict[str, set[str]]:
    """Names of the bodies, loads and boundaries active in phase ``index``: an item is on from the
    start unless some phase activates it, then switched by each phase's lists in turn."""
    phases = scene.phases
    activated = {name for p in phases for name in p.activate}
    out = {}
    for section in SWITCHED:
        names = {item.name for item in getattr(scene, section)}
        on = {n for n in names if n not in activated}
        for p in phases[: index + 1]:
            on |= names & set(p.activate)
            on -= set(p.deactivate)
        out[section] = on
    return out


def phase_scene(scene: Scene, index: int) -> Scene:
    """The scene phase ``index`` runs: changes of phases 0..index applied, inactive items left out
    (probes on a plane that is off too), no phases of its own."""
    out = copy.deepcopy(scene)
    out.phases = []
    for k, phase in enumerate(scene.phases[: index + 1]):
        for path, value in phase.changes.items():
            set_key(out, path, value, f"phases.{phase_label(phase, k)}.changes")
    on = active_items(scene, index)
    for section in SWITCHED:
        setattr(out, section, [item for item in getattr(out, section) if item.name in on[section]])
    planes = {item.name for section in ("loads", "boundaries") for item in getattr(out, section)}
    out.probes = [p for p in out.probes if p.kind != "reaction" or p.boundary in planes]
    return out


def phase_label(phase: Phase, index: int) -> str:
    """How messages name phase ``index``: its name, or ``[index]`` without a usable one."""
    return phase.name if isinstance(phase.name, str) and phase.name else f"[{index}]"


def set_key(scene: Scene, path: str, value, where: str) -> None:
    """Set the scene key ``path`` (``materials.soil.cohesion``, ``loads.top.traction``, ...) to ``value``,
    a value of the key's type (a validated phase's changes are: :func:`warpsph.scene.Scene.validate`)."""
    owner, name = change_target(scene, path, where)
    setattr(owner, name, value)


def change_target(scene: Scene, path: str, where: str) -> tuple[object, str]:
    """The dataclass instance of ``scene`` that holds the key ``path`` and the key's field name; errors
    name ``where.path``."""
    key = f"{where}.{path}"
    parts = path.split(".")
    if not all(parts) or len(parts) < 2:
        raise SceneError(key, "expected a key path such as materials.soil.cohesion")
    node = scene
    for depth, part in enumerate(parts[:-1]):
        here = ".".join(parts[: depth + 1])
        if isinstance(node, dict):
            if part not in node:
                raise SceneError(key, f"no {here}; defined: {', '.join(sorted(node)) or 'none'}")
            node = node[part]
        elif isinstance(node, list):
            names = [item.name for item in node]
            if part not in names:
                raise SceneError(key, f"no {here}; defined: {', '.join(names) or 'none'}")
            node = node[names.index(part)]
        elif dataclasses.is_dataclass(node) and part in _fields(node) and part not in ("phases", "source_text"):
            node = getattr(node, part)
        else:
            raise SceneError(key, f"{here} is not a scene key")
        if node is None:
            raise SceneError(key, f"{here} is not set in the scene, so it has no keys to change")
    last = parts[-1]
    if not dataclasses.is_dataclass(node) or last not in _fields(node) or last == "name":
        raise SceneError(key, f"{path} is not a scene key that a phase can change")
    return node, last


def _fields(obj) -> set[str]:
    return {f.name for f in dataclasses.fields(obj)}

