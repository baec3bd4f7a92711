"""Limit equilibrium on a model's particles (warpsph/phases/limit_equilibrium.py, docs/scenes.md *Limit
equilibrium*): Bishop's simplified method and Spencer's on the critical circle, against published values
(the ACADS EX1(a) referee slope, Griffiths & Lane's example 1, Taylor's chart) and against the same
method on the continuous outline, integrated here with fine slices."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warpsph.phases.limit_equilibrium import (EVERYWHERE, above_the_floor, bishop, critical_circle, ground, slices,
                                              spencer)
from warpsph.phases.safety import floor_warnings

GAMMA = 20e3


def gl(x):
    """Griffiths & Lane's example 1: a 2:1 slope 10 m high on 2 m of the same soil."""
    return np.where(x <= 12, 2.0, np.where(x >= 32, 12.0, 2 + (x - 12) / 2))


def acads(x):
    """ACADS EX1(a): a 2:1 slope 10 m high from (30, 25) to (50, 35) over ground from x = 20 to 70 on a
    base at y = 20 (here shifted by (−20, −20))."""
    return np.where(x <= 10, 5.0, np.where(x >= 30, 15.0, 5 + (x - 10) / 2))


def particles(surface, width: float, dx: float, cohesion: float, phi: float, pore=None, suction: bool = False):
    """The ground of the particles of a lattice ``dx`` under ``surface`` from x = 0 to ``width``."""
    xs, ys = np.meshgrid(np.arange(dx / 2, width, dx), np.arange(dx / 2, 40.0, dx), indexing="ij")
    inside = ys < surface(xs)
    p = np.stack([xs[inside], ys[inside], np.zeros(inside.sum())], axis=1)
    n = len(p)
    u = None if pore is None else pore(p[:, 0], p[:, 1])
    return ground(p, np.full(n, GAMMA * dx * dx), np.full(n, cohesion), np.full(n, math.tan(math.radians(phi))), u, dx,
                  suction=suction)


def continuous_bishop(surface, cohesion: float, phi: float, circle, pore=None, n: int = 20000) -> float:
    """Bishop's factor of ``circle`` (x, y, r) under ``surface`` (above y = 0) in ``n`` slices."""
    xc, yc, r = circle
    x = np.linspace(xc - r, xc + r, n + 1)
    x, b = 0.5 * (x[1:] + x[:-1]), 2 * r / n
    base = yc - np.sqrt(np.maximum(r * r - (x - xc) ** 2, 0.0))
    w = GAMMA * b * np.maximum(surface(x) - base, 0.0)
    cut = w > 0
    u = np.zeros_like(x) if pore is None else np.maximum(pore(x, base), 0.0)
    sin = (x - xc) / r
    sin = -sin if np.sum(w * sin) < 0 else sin
    cos, t, f = np.sqrt(1 - sin * sin), math.tan(math.radians(phi)), 1.0
    for _ in range(200):
        f = np.sum(((cohesion * b + (w - u * b) * t) / (cos + sin * t / f))[cut]) / np.sum((w * sin)[cut])
    return float(f)


def test_acads_referee_slope():
    """ACADS EX1(a) (c′ = 3 kPa, φ′ = 19.6°, γ = 20 kN/m³): referee 1.00, 0.993 the mean of 18 Bishop
    programs; measured at Δx = 0.25 m Bishop 0.983, Spencer 0.982 (the same method on the continuous
    outline 0.985)."""
    found = critical_circle(particles(acads, 50.0, 0.25, 3e3, 19.6))
    print(f"\nACADS EX1(a): Bishop {found.bishop:.4f}, Spencer {found.spencer:.4f}, {found}")
    assert found.bishop == pytest.approx(1.0, rel=0.02) and found.bishop == pytest.approx(0.993, rel=0.015)
    assert found.spencer == pytest.approx(found.bishop, rel=0.005)  # a circle: both near, Spencer a little below


def test_griffiths_lane_example_1():
    """c′ = 10 kPa, φ′ = 20°: Bishop 1.38 by Bishop & Morgenstern's charts (Griffiths & Lane 1999);
    measured 1.360 at Δx = 0.5 m (the shipped slope_fos is at 1 m: 1.351)."""
    found = critical_circle(particles(gl, 44.0, 0.5, 10e3, 20.0))
    print(f"\nGriffiths & Lane: Bishop {found.bishop:.4f}, Spencer {found.spencer:.4f}, {found}")
    assert found.bishop == pytest.approx(1.38, rel=0.02) and found.spencer == pytest.approx(1.38, rel=0.02)


def test_particles_converge_to_the_continuous_outline():
    """The particle version's critical factor approaches the continuous one's on its own circle, about
    linearly in Δx (the surface's staircase): measured −1.2, −0.6, −0.3 %."""
    errors = []
    for dx in (1.0, 0.5, 0.25):
        found = critical_circle(particles(gl, 44.0, dx, 10e3, 20.0))
        exact = continuous_bishop(gl, 10e3, 20.0, (*found.centre, found.radius))
        errors.append(abs(found.bishop / exact - 1.0))
    print(f"\nrelative errors {errors}")
    assert errors[0] < 0.02 and errors[1] < 0.6 * errors[0] + 1e-3 and errors[2] < 0.6 * errors[1] + 1e-3


def test_undrained_slope_against_taylors_chart():
    """A 60° slope 2 m high in clay of c_u = 12 kPa (φ = 0, γ = 19.62 kN/m³) on 1 m of it (the undrained
    slope of the validation manual): Taylor's stability number 0.191 gives F = 1.601; measured 1.597 at
    Δx = 0.05 m. Spencer's method finds no inclination of parallel interslice forces within ±1.2 rad that
    balances this circle (φ = 0)."""
    crest = 2.0 + 2.0 / math.tan(math.radians(60.0))

    def slope(x):
        return np.where(x <= 2.0, 1.0, np.where(x >= crest, 3.0, 1.0 + (x - 2.0) * math.tan(math.radians(60.0))))

    dx = 0.05
    xs, ys = np.meshgrid(np.arange(dx / 2, 8.0, dx), np.arange(dx / 2, 3.0, dx), indexing="ij")
    inside = ys < slope(xs)
    p = np.stack([xs[inside], ys[inside], np.zeros(inside.sum())], axis=1)
    n = len(p)
    found = critical_circle(ground(p, np.full(n, 19.62e3 * dx * dx), np.full(n, 12e3), np.zeros(n), None, dx))
    print(f"\n60° undrained slope: Bishop {found.bishop:.4f}, {found}")
    assert found.bishop == pytest.approx(12e3 / (0.191 * 19.62e3 * 2.0), rel=0.01)


def test_cohesionless_slope_fails_along_its_face():
    """c′ = 0: the critical circles shrink to the face, where F = tan φ′ / tan β (1.155 for φ′ = 30° on
    2:1); the particle version is within 3 % from above (its shallowest circle cuts 3 columns)."""
    found = critical_circle(particles(gl, 44.0, 0.5, 0.0, 30.0))
    assert found.bishop == pytest.approx(math.tan(math.radians(30.0)) / 0.5, rel=0.03)


def test_pore_pressure_lowers_the_factor_as_on_the_continuous_outline():
    """A water table at the toe's level, hydrostatic below it: Bishop's factor falls, and matches the
    continuous version with the same pressures on the same circle within 1 %."""
    def pore(x, y):
        return 9.81e3 * np.maximum(2.0 - y, 0.0)

    dry = critical_circle(particles(gl, 44.0, 0.5, 10e3, 20.0))
    wet = critical_circle(particles(gl, 44.0, 0.5, 10e3, 20.0, pore))
    exact = continuous_bishop(gl, 10e3, 20.0, (*wet.centre, wet.radius), pore)
    print(f"\ndry {dry.bishop:.4f}, wet {wet.bishop:.4f}, continuous {exact:.4f}")
    assert wet.bishop < dry.bishop - 0.01 and wet.bishop == pytest.approx(exact, rel=0.01)


def test_a_body_that_does_not_yield_has_no_slip_circle_through_it():
    g = particles(gl, 44.0, 0.5, math.inf, 0.0)
    assert critical_circle(g) is None or not math.isfinite(critical_circle(g).bishop)


def test_spencer_balances_forces_and_moments():
    """On one circle, Spencer's factor and θ make ΣQ and ΣQ cos(α − θ) vanish; its factor lies within
    1 % of Bishop's (circles)."""
    g = particles(gl, 44.0, 0.5, 10e3, 20.0)
    s = slices(g, np.array([[15.3, 25.2, 23.4]]))
    f_bishop = float(bishop(s)[0])
    f, theta = spencer(s, 0, f_bishop)
    assert f == pytest.approx(f_bishop, rel=0.01) and 0.0 < theta < 0.6


def embankment(x):
    """An embankment 6 m high on 2 m of the same soil: its left slope 1:2.5 from x = 5 to 20 m, a crest
    to x = 24 m, its right slope 1:1.5 to x = 33 m, over ground 40 m wide."""
    left = 2.0 + (x - 5.0) / 2.5
    right = 8.0 - (x - 24.0) / 1.5
    return np.clip(np.minimum(left, right), 2.0, 8.0)


def test_a_slip_region_keeps_the_search_within_it():
    """``region`` (x from, x to, lowest y): unrestricted, the steeper right slope of an embankment is the
    critical one; within x < 22 m the left slope's circle is found, every cut column inside the region
    and its factor higher; a region holding the whole model changes nothing."""
    g = particles(embankment, 40.0, 0.5, 8e3, 28.0)
    free = critical_circle(g)
    left = critical_circle(g, (-math.inf, 22.0, -math.inf))
    whole = critical_circle(g, (0.0, 40.0, 0.0))
    print(f"\nunrestricted {free.bishop:.4f} at {free.centre}, left of 22 m {left.bishop:.4f} at {left.centre}")
    assert free.centre[0] > 22.0 and left.centre[0] < 22.0 and left.bishop > free.bishop
    s = slices(g, np.array([[*left.centre, left.radius]]))
    assert np.all(g.x[s.weight[0] > 0.0] <= 22.0)
    assert (whole.bishop, whole.centre, whole.radius) == (free.bishop, free.centre, free.radius)


def test_a_slip_region_bounds_the_circle_from_below():
    """Griffiths & Lane's slope with the slip kept above the toe's level (y ≥ 2 m, the foundation's top):
    the deepest arc point found lies at or above it, the factor at or above the unrestricted one, and
    within 1 % of the same method on the continuous outline."""
    g = particles(gl, 44.0, 0.5, 10e3, 20.0)
    free, shallow = critical_circle(g), critical_circle(g, (-math.inf, math.inf, 2.0))
    (xc, yc), r = shallow.centre, shallow.radius
    s = slices(g, np.array([[xc, yc, r]]))
    cut = g.x[s.weight[0] > 0.0]
    lowest = float(np.min(yc - np.sqrt(r * r - (cut - xc) ** 2)))
    exact = continuous_bishop(gl, 10e3, 20.0, (xc, yc, r))
    print(f"\nunrestricted {free.bishop:.4f}, above y = 2 m {shallow.bishop:.4f} (lowest {lowest:.3f} m), "
          f"continuous {exact:.4f}")
    assert lowest >= 2.0 - 1e-9 and shallow.bishop >= free.bishop and shallow.bishop == pytest.approx(exact, rel=0.01)


def test_a_slip_region_missing_the_ground_finds_no_circle():
    assert critical_circle(particles(gl, 44.0, 0.5, 10e3, 20.0), (50.0, 60.0, -math.inf)) is None


def submerged(level: float, buoyant: bool, dx: float = 0.5):
    """Griffiths & Lane's slope (c′ = 10 kPa, φ′ = 20°, γ_sat = 20 kN/m³) with still water to ``level``:
    its pore pressure hydrostatic and free water on its surface, or (``buoyant``) the same soil weighing
    γ_sat − γ_w below the level, dry."""
    xs, ys = np.meshgrid(np.arange(dx / 2, 44.0, dx), np.arange(dx / 2, 40.0, dx), indexing="ij")
    inside = ys < gl(xs)
    p = np.stack([xs[inside], ys[inside], np.zeros(inside.sum())], axis=1)
    n, water = len(p), 9.81e3
    c, t = np.full(n, 10e3), np.full(n, math.tan(math.radians(20.0)))
    if buoyant:
        return ground(p, np.where(p[:, 1] < level, GAMMA - water, GAMMA) * dx * dx, c, t, None, dx)
    u = water * np.maximum(level - p[:, 1], 0.0)
    return ground(p, np.full(n, GAMMA * dx * dx), c, t, u, dx, water, lambda x, y: water * (level - y))


@pytest.mark.parametrize("level", [5.0, 11.0, 20.0])
def test_still_water_on_a_slope_acts_as_its_buoyancy(level):
    """Water standing on a slope (to mid-height, just below the crest, over it), its pore pressure
    hydrostatic: the free water's weight and its thrust on the sliding mass's ends, with the pore
    pressure on the slip surface, balance as buoyancy does, so Bishop's and Spencer's factors and the
    critical circle are those of the slope weighing γ_sat − γ_w below the water, dry (measured within
    0.03 % and 0.25 %)."""
    wet, light = critical_circle(submerged(level, False)), critical_circle(submerged(level, True))
    print(f"\nlevel {level}: with water {wet.bishop:.4f} / {wet.spencer:.4f}, buoyant {light.bishop:.4f} / "
          f"{light.spencer:.4f}")
    assert wet.bishop == pytest.approx(light.bishop, rel=2e-3) and wet.spencer == pytest.approx(light.spencer, rel=5e-3)
    assert wet.centre == pytest.approx(light.centre, abs=0.5) and wet.radius == pytest.approx(light.radius, abs=0.5)


def clay_on_rock(x):
    """An undrained 2:1 slope 6 m high on 6 m of the same clay over rock at y = 0."""
    return np.where(x <= 10, 6.0, np.where(x >= 22, 12.0, 6 + (x - 10) / 2))


def test_a_circle_along_the_bottom_is_reported_above_the_lowest_row():
    """The deep circle of an undrained slope on clay over rock is tangent to the rock (Taylor's base failure),
    where the particles' lowest row does not shear: Bishop's factor with the arcs kept above that row is
    reported beside it and is higher; a circle through the toe of Griffiths & Lane's slope stays above
    the row and reports none."""
    dx = 0.5
    clay = particles(clay_on_rock, 40.0, dx, 20e3, 0.0)
    deep = critical_circle(clay)
    raised = above_the_floor(clay, EVERYWHERE, deep)
    lowest = deep.centre[1] - deep.radius
    print(f"\nalong the rock {deep.bishop:.4f} (arc down to {lowest:.3f} m), above the row {raised:.4f}")
    assert lowest < dx  # down to the rock
    assert raised > deep.bishop * 1.005  # measured 0.974 and 0.981
    assert raised == critical_circle(clay, (-math.inf, math.inf, clay.bottom + 1.5 * dx)).bishop
    toe = particles(gl, 44.0, dx, 10e3, 20.0)
    assert math.isnan(above_the_floor(toe, EVERYWHERE, critical_circle(toe)))


def test_a_circle_along_a_stronger_layer_is_reported_above_it():
    """The same slope with its lowest 3 m three times as strong: the critical circle runs along the top of
    that layer, and Bishop's factor is reported with the arcs kept a spacing above the layer's top row."""
    dx = 0.5
    xs, ys = np.meshgrid(np.arange(dx / 2, 40.0, dx), np.arange(dx / 2, 40.0, dx), indexing="ij")
    inside = ys < clay_on_rock(xs)
    p = np.stack([xs[inside], ys[inside], np.zeros(inside.sum())], axis=1)
    cohesion = np.where(p[:, 1] < 3.0, 60e3, 20e3)
    layered = ground(p, np.full(len(p), GAMMA * dx * dx), cohesion, np.zeros(len(p)), None, dx)
    deep = critical_circle(layered)
    raised = above_the_floor(layered, EVERYWHERE, deep)
    lowest = deep.centre[1] - deep.radius
    print(f"\nalong the layer {deep.bishop:.4f} (arc down to {lowest:.3f} m), above it {raised:.4f}")
    assert 2.75 < lowest < 3.25
    assert raised == critical_circle(layered, (-math.inf, math.inf, 2.75 + dx)).bishop > deep.bishop


def test_a_factor_that_rises_off_the_rows_that_do_not_shear_is_warned_about():
    """More than 2 % higher above the lowest row (the earth dam of scenes/dam_rapid_drawdown.toml at full
    reservoir, Δx = 0.5 m: 1.474 and 1.544) warns, naming the spacing at which the rise would be 2 %."""
    (line,) = floor_warnings([1.474, 1.477, 31.7, 16.6, 16.7, 1.544], 0.5)
    assert "1.474 there and 1.544 a row above them (+4.7 %)" in line and line.endswith("set simulation.dx to 0.21 m or "
                                                                                    "less (now 0.5 m)")  # fmt: skip
    assert floor_warnings([1.0, 1.0, 0.0, 0.0, 1.0, 1.019], 0.5) == [] == floor_warnings([1.0] * 5, 0.5)
    assert floor_warnings([1.0, 1.0, 0.0, 0.0, 1.0, math.nan], 0.5) == []


@pytest.mark.parametrize("suction", [False, True])
def test_suction_counted_adds_its_share_to_the_normal_stress(suction):
    """A uniform pore pressure −s: ignored (the default) it counts as zero; counted (Bishop's χ p_w of the
    effective stress) it adds s tan φ′ to every slice's strength: the factor of the same ground with c′ +
    s tan φ′ and no pore pressure (to round-off)."""
    s, c, phi = 5e3, 10e3, 20.0
    wet = critical_circle(particles(gl, 44.0, 0.5, c, phi, lambda x, y: np.full(len(x), -s), suction))
    same = critical_circle(particles(gl, 44.0, 0.5, c + (s * math.tan(math.radians(phi)) if suction else 0.0), phi))
    print(f"\nBishop {wet.bishop:.4f}")
    assert wet.bishop == pytest.approx(same.bishop, rel=1e-12)
