"""Consolidation phases: the coupled quasi-static transient in implicit steps, each a fixed-stress
split of the flow and the skeleton's equilibrium (docs/scenes.md, *Phases*)."""

from __future__ import annotations

from warpsph.model import State
from warpsph.phases.equilibrium import Equilibrium
from warpsph.phases.flow import Flow
from warpsph.stages.consolidation import FixedStressSplit


class Consolidation(Flow):
    """The coupled quasi-static transient of the phase's duration (:class:`FixedStressSplit`,
    :meth:`~warpsph.phases.flow.Flow.implicit_steps`): the flow with the skeleton's stresses fixed,
    then the skeleton's damped equilibrium under the pore pressures held, until the two agree."""

    damped = True

    @property
    def pore_pressure(self) -> str:
        return "fixed"

    def build(self) -> None:
        super().build()
        self.skeleton = Equilibrium(self.run, self.phase)
        self.split = FixedStressSplit(self.run.model, self.run.solver, self.flow, self.equilibrate_held,
                                      lambda: self.run.state)  # fmt: skip

    def calculate(self, progress) -> str:
        return self.implicit_steps(self.split, progress)

    def equilibrate_held(self, t: float) -> tuple[bool, State]:
        """A consolidation iterate's skeleton: equilibrium under the state's pore pressures held, the
        loads at phase time ``t`` [s]; (converged within the phase's step cap, the state)."""
        run = self.run
        run.loop["time"] = t
        run.scratch.assign(run.state)
        run.solver.hold_pore_pressure(run.state, suction=1)  # the split's iterates: the water's own tension
        run.loop.pop("ratio", None)
        converged, _ratio = self.skeleton.equilibrate(None, run.step_index, output=False)
        return converged, run.state
