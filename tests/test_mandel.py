"""Mandel's problem (``scenes/mandel.toml``; docs/validation, *Mandel's problem*): a saturated specimen between
rigid smooth impermeable plates, its sides drained, under a force switched on at t = 0, against the closed
form of Cheng & Detournay (1988) (``warpsph.verification.mandel_pressure`` and ``mandel_settlement``), in the
shipped consolidation phase and as a dynamic saturated run from the undrained state
(``warpsph.validation.mandel`` builds both and measures them).
"""

import pytest

from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.validation.mandel import FORCE, HALF_WIDTH, centre_rise, mandel_scene, measured


def report(rows, rise) -> None:
    print("\n  T      L2/p0    settlement [µm]  closed form")
    for tv, l2, settlement, exact in rows:
        print(f"  {tv:.3f}  {l2:.4f}   {settlement * 1e6:8.2f}       {exact * 1e6:8.2f}")
    print(f"the centre's largest pressure {rise[0]:.4f} p0, the closed form's peak {rise[1]:.4f} p0")


def test_consolidation_phase_follows_the_closed_form(tmp_path):
    """The shipped consolidation phase to T = 0.2 (frames at T = 0.05, 0.1, 0.15, 0.2), the load switched
    on at its start: p(x) within 2 % of p(0, 0⁺) (L2), the settlement within 2 %, the centre's pressure
    rising above its undrained value to within 2.5 % of the closed form's peak (−2.2 % at Δx = 0.1 m,
    sampled at the frames)."""
    scene, m = mandel_scene(0.2, 4)
    Run(scene, tmp_path).run()
    results = load_results(tmp_path / "results.h5")
    rows, rise = measured(results, m, undrained_start=False), centre_rise(results, m)
    report(rows, rise)
    for tv, l2, settlement, exact in rows:
        assert l2 < 0.02
        assert settlement == pytest.approx(exact, rel=0.02)
    assert 1.0 < rise[0] == pytest.approx(rise[1], rel=0.025)


def test_dynamic_saturated_run_follows_the_closed_form_and_stays_stable_to_t_1(tmp_path):
    """A dynamic run from the undrained state to T = 1: p(x) within 2 % of p(0, 0⁺) (L2) at every tenth
    of T, the settlement within 2 % from T = 0.2 on (the drained side's first row consolidates at once,
    a first-order lag before), the centre's rise within 2 % of the peak, no suction, finished."""
    scene, m = mandel_scene(1.0, 10, dynamic=True)
    summary = Run(scene, tmp_path).run()
    results = load_results(tmp_path / "results.h5")
    rows, rise = measured(results, m, undrained_start=True), centre_rise(results, m)
    report(rows, rise)
    assert summary.status == "finished"
    for tv, l2, settlement, exact in rows:
        assert l2 < 0.02
        if tv > 0.19:
            assert settlement == pytest.approx(exact, rel=0.02)
    assert rise[0] == pytest.approx(rise[1], rel=0.02)
    lowest = min(results.frame(i)["pore_pressure"].min() for i in range(len(results)))
    assert lowest >= -0.01 * FORCE / HALF_WIDTH


@pytest.mark.slow
def test_shipped_scene_to_t_1(tmp_path):
    """The shipped scene as it is (T = 1, 20 frames, about 90 s on one core): p(x) within 2 % (L2) and the
    settlement within 2 % at every frame."""
    scene, m = mandel_scene(1.0, 20)
    Run(scene, tmp_path).run()
    for tv, l2, settlement, exact in measured(load_results(tmp_path / "results.h5"), m, undrained_start=False):
        assert l2 < 0.02
        assert settlement == pytest.approx(exact, rel=0.02)
