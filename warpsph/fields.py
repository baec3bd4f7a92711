"""Host-side (NumPy) views of particle fields: Voigt conversion and stress invariants."""

from __future__ import annotations

import numpy as np


def voigt_to_tensor(voigt) -> np.ndarray:
    """(…,6) Voigt xx, yy, zz, yz, xz, xy → (…,3,3) symmetric tensors."""
    v = np.asarray(voigt, dtype=float)
    xx, yy, zz, yz, xz, xy = (v[..., i] for i in range(6))
    return np.stack([np.stack([xx, xy, xz], -1), np.stack([xy, yy, yz], -1), np.stack([xz, yz, zz], -1)], -2)


def tensor_to_voigt(t: np.ndarray) -> np.ndarray:
    """(…,3,3) → (…,6) Voigt xx, yy, zz, yz, xz, xy."""
    return np.stack([t[..., 0, 0], t[..., 1, 1], t[..., 2, 2], t[..., 1, 2], t[..., 0, 2], t[..., 0, 1]], -1)


def mean_stress(t: np.ndarray) -> np.ndarray:
    """tr(σ)/3 [Pa] of (…,3,3) tensors (tension positive)."""
    return np.trace(t, axis1=-2, axis2=-1) / 3.0


def von_mises(t: np.ndarray) -> np.ndarray:
    """√(3 J₂) [Pa] of (…,3,3) tensors."""
    dev = t - mean_stress(t)[..., None, None] * np.eye(3)
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", dev, dev))
