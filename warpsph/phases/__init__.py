"""Staged analysis: one module per phase kind, each a calculation over the run's model and state
(:mod:`~warpsph.phases.k0`, ``equilibrium``, ``safety``, ``dynamic``, ``flow``, ``consolidation``);
``staging`` the scene each phase runs and its record, ``carry`` the state carried between phases'
models, ``search`` strength reduction and the factor-of-safety search (docs/scenes.md, *Phases*).
"""

from warpsph.phases.search import FactorSearch, reduced_strength
from warpsph.phases.staging import (AT_REST, CONVERGED, FINISHED, NOT_CONVERGED, STOPPED, SWITCHED, UNSTABLE,
                                    PhaseRecord, active_items, change_target, default_phases, phase_label, phase_scene,
                                    set_key)  # fmt: skip

__all__ = ["AT_REST", "CONVERGED", "FINISHED", "NOT_CONVERGED", "STOPPED", "SWITCHED", "UNSTABLE", "FactorSearch",
           "PhaseRecord", "active_items", "change_target", "default_phases", "phase_label", "phase_scene",
           "reduced_strength", "set_key"]  # fmt: skip
