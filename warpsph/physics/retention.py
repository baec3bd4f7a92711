"""Water retention of partially saturated soil: degree of saturation, its slope and the relative
permeability as functions of the pore pressure (docs/scenes.md, *Groundwater flow*).

van Genuchten–Mualem: S_e = [1 + (α ψ)ⁿ]^(−m), m = 1 − 1/n, k_r = √S_e [1 − (1 − S_e^(1/m))^m]²;
Gardner: S_e = k_r = exp(−α ψ); ψ = −p/(ρ_w g) ≥ 0 is the suction head and S = S_r + (1 − S_r) S_e.
Saturated soil (and any soil at p ≥ 0) has S = k_r = 1; k_r never falls below
RELATIVE_PERMEABILITY_FLOOR. Float64 throughout.
"""

import warp as wp

RETENTION = {"saturated": 0, "van_genuchten": 1, "gardner": 2}
"""Material ``retention`` names and their codes in the kernels."""

RELATIVE_PERMEABILITY_FLOOR = 1.0e-6
"""Least k_r [-]: dry soil still conducts a millionth of its saturated conductivity, which carries no
water that matters but keeps its pore pressure determined (with k_r of 1e-15 at a metre of suction,
a dam's dry crest drifted by tens of kPa between iterations and the steady flow did not converge)."""

f64 = wp.float64


FLOOR = wp.constant(f64(RELATIVE_PERMEABILITY_FLOOR))


@wp.func
def retention_state(kind: int, alpha: f64, n: f64, residual: f64, rho_g: f64, p: f64):
    """(S, dS/dp [1/Pa], k_r) at total pore pressure ``p`` [Pa] for retention ``kind`` with α [1/m],
    van Genuchten n, residual saturation S_r and ρ_w g [Pa/m]."""
    one = f64(1.0)
    if kind == 0 or p >= f64(0.0):
        return one, f64(0.0), one
    suction = -p / rho_g
    if kind == 2:
        se = wp.exp(-alpha * suction)
        return residual + (one - residual) * se, (one - residual) * alpha * se / rho_g, wp.max(se, FLOOR)
    m = one - one / n
    scaled = wp.pow(alpha * suction, n)
    se = wp.pow(one + scaled, -m)
    slope = m * n * alpha * wp.pow(alpha * suction, n - one) * wp.pow(one + scaled, -m - one) / rho_g
    mualem = one - wp.pow(one - wp.pow(se, one / m), m)
    return residual + (one - residual) * se, (one - residual) * slope, wp.max(wp.sqrt(se) * mualem * mualem, FLOOR)


@wp.struct
class RetentionLaws:
    """Each material's water retention, as the kernels take it: the law's code (:data:`RETENTION`),
    α [1/m], van Genuchten n [-] and the residual saturation S_r [-], (n_materials,) each."""

    kind: wp.array(dtype=wp.int32)
    alpha: wp.array(dtype=f64)
    n: wp.array(dtype=f64)
    residual: wp.array(dtype=f64)


def retention_laws(kind: wp.array, alpha: wp.array, n: wp.array, residual: wp.array) -> RetentionLaws:
    """The :class:`RetentionLaws` of these per-material arrays."""
    laws = RetentionLaws()
    laws.kind, laws.alpha, laws.n, laws.residual = kind, alpha, n, residual
    return laws


@wp.func
def material_retention_state(laws: RetentionLaws, mat: int, rho_g: f64, p: f64):
    """:func:`retention_state` with material ``mat``'s law."""
    return retention_state(laws.kind[mat], laws.alpha[mat], laws.n[mat], laws.residual[mat], rho_g, p)
