"""What every phase kind's calculation shares: its place in the run, the check cadence, the stop at
``--end-time`` (docs/scenes.md, *Phases*)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from warpsph.scene import Phase

CHECK_EVERY = 10
"""Steps between two reads of an equilibrium phase's unbalanced force, a dynamic phase's kinetic
energy, or the energy balance written as series: each read waits for the device."""


class Stopped(Exception):
    """``--end-time`` reached inside a phase."""


class Calculation:
    """A phase kind's calculation over the run's model and state: what it builds on entering the phase
    (:meth:`prepare` before the solver, :meth:`build` after), and its loop (:meth:`calculate`), which steps,
    writes and checkpoints through the run (:class:`~warpsph.runner.Run`)."""

    damped = False
    """Whether its explicit steps are locally damped (quasi-static)."""
    flow = None
    """The groundwater flow it solves (:class:`~warpsph.stages.groundwater.GroundwaterFlow`), if any."""
    split = None
    """The fixed-stress split of a consolidation (:class:`~warpsph.stages.consolidation.FixedStressSplit`)."""

    def __init__(self, run, phase: Phase):
        self.run, self.phase = run, phase
        """The :class:`~warpsph.runner.Run` it steps, writes and checkpoints through, and its phase."""

    @property
    def pore_pressure(self) -> str:
        """How its steps treat the pore pressure ("coupled", "fixed", ...: ``Phase.pore_pressure``)."""
        return self.phase.pore_pressure

    def prepare(self) -> None:
        """Set up the phase's start state, before its solver is built."""

    def build(self) -> None:
        """Build what the calculation owns, once the run's solver and state are ready."""

    def calculate(self, progress) -> str:
        """Run the phase to its end; its outcome (``warpsph.phases.CONVERGED``, ...)."""
        raise NotImplementedError

    def checkpoint_arrays(self) -> dict:
        """Arrays the calculation keeps in the run's checkpoint beside the state (:meth:`restore` takes them back)."""
        return {}

    def restore(self, arrays: dict) -> None:
        """Take back what :meth:`checkpoint_arrays` kept, resuming from a checkpoint's ``arrays`` (the run's
        loop already restored)."""

    def warnings(self, record) -> list[str]:
        """One line per thing the phase's result (``record``, a :class:`~warpsph.phases.staging.PhaseRecord`)
        should make its user doubt, each saying what to change (the command line prints them)."""
        return []
