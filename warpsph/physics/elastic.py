"""Linear hypo-elastic law with the Jaumann rate, and the Runge–Kutta source integrator.

The flux part of the stress equation is Hooke's law on the rate of deformation,
dσ′/dt = λ tr(d) I + 2G d; the source part is the Jaumann spin term S(σ′) = Wσ′ − σ′W (method.md
§2.4), integrated over an interval by RK2 (midpoint) or RK4 with the spin W held fixed.
"""


import functools

import warp as wp

from warpsph.sph.spec import Spec


@functools.cache
def elastic_struct(spec: Spec):
    """The ``ElasticMaterials`` @wp.struct of ``spec``'s precision: per material, Lamé's λ [Pa], the
    shear modulus G [Pa] and the drained P-wave speed [m/s], as every kernel of the elastic law takes them."""
    real = spec.real

    @wp.struct
    class ElasticMaterials:
        lam: wp.array(dtype=real)
        shear: wp.array(dtype=real)
        wave_speed: wp.array(dtype=real)

    return ElasticMaterials


@functools.cache
def elastic_functions(spec: Spec):
    """Return ``(hooke_rate, source_increment, split_velocity_gradient)`` Warp functions."""
    real, mat33 = spec.real, spec.mat33
    half = real(0.5)

    @wp.func
    def hooke_rate(d: mat33, lam: real, shear: real):
        """Stress rate λ tr(d) I + 2G d [Pa/s] for rate of deformation d [1/s]."""
        return (lam * wp.trace(d)) * wp.identity(3, dtype=real) + (real(2.0) * shear) * d

    @wp.func
    def jaumann(sigma: mat33, spin: mat33):
        return spin * sigma - sigma * spin

    if spec.integrator == "rk4":

        @wp.func
        def source_increment(sigma: mat33, spin: mat33, dt: real):
            """RK4 increment of dσ/dt = Wσ − σW over dt [s]."""
            k1 = jaumann(sigma, spin)
            k2 = jaumann(sigma + (half * dt) * k1, spin)
            k3 = jaumann(sigma + (half * dt) * k2, spin)
            k4 = jaumann(sigma + dt * k3, spin)
            return (dt / real(6.0)) * (k1 + real(2.0) * k2 + real(2.0) * k3 + k4)

    else:

        @wp.func
        def source_increment(sigma: mat33, spin: mat33, dt: real):
            """RK2 (midpoint) increment of dσ/dt = Wσ − σW over dt [s]."""
            k1 = jaumann(sigma, spin)
            return dt * jaumann(sigma + (half * dt) * k1, spin)

    @wp.func
    def split_velocity_gradient(G: mat33):
        """From G[k, j] = ∂v_j/∂x_k return (d, W): rate of deformation and spin of L = Gᵀ."""
        L = wp.transpose(G)
        return half * (L + G), half * (L - G)

    return hooke_rate, source_increment, split_velocity_gradient


@functools.cache
def strain_energy_function(spec: Spec):
    """The Warp function ``strain_energy_density(σ′, λ, G)``: ½ σ′:C⁻¹:σ′ [J/m³], the elastic energy
    the linear law stores in a stress state (plane strain keeps σ′_zz, so the 3D compliance is exact)."""
    real, mat33 = spec.real, spec.mat33

    @wp.func
    def strain_energy_density(s: mat33, lam: real, shear: real):
        tr = wp.trace(s)
        return (wp.ddot(s, s) - lam / (real(3.0) * lam + real(2.0) * shear) * tr * tr) / (real(4.0) * shear)

    return strain_energy_density
