"""Strong ellipticity of a point material: the smallest eigenvalue of its acoustic tensor.

A finite-strain law is strongly elliptic at ``F`` when the acoustic tensor
``Q_ik(N) = A_iJkL N_J N_L`` is positive definite for every unit direction ``N``, with
``A = dP/dF = I (x) S + F D F`` the first elasticity tensor (``D = dS/dE_GL``, the
kernel's tangent). Where it is not, the equilibrium equations admit discontinuous
(localised) solutions and Newton on the discrete problem loses its footing; see
docs/theory.md, section 13.
"""

from __future__ import annotations

import numpy as np

from forming.materials.solids import PointMaterial, evaluate

_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))  # Mandel component -> (i, j)
_W = np.array([1.0, 1.0, 1.0, np.sqrt(2.0), np.sqrt(2.0), np.sqrt(2.0)])


def sphere_directions(n: int = 2000, seed: int = 0) -> np.ndarray:
    """``n`` random unit vectors plus the axes and the in-plane and axial diagonals."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d = np.vstack([d, np.eye(3), [[1, 1, 0], [1, -1, 0], [1, 0, 1], [0, 1, 1]]])
    return d / np.linalg.norm(d, axis=1)[:, None]


def _tensors(s_mandel: np.ndarray, d_mandel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """S (3 x 3) and D (3 x 3 x 3 x 3, minor symmetric) from their Mandel forms."""
    s, d = np.zeros((3, 3)), np.zeros((3, 3, 3, 3))
    for a, (i, j) in enumerate(_PAIRS):
        s[i, j] = s[j, i] = s_mandel[a] / _W[a]
        for b, (k, m) in enumerate(_PAIRS):
            value = d_mandel[a, b] / (_W[a] * _W[b])
            for p, q in {(i, j), (j, i)}:
                for r, t in {(k, m), (m, k)}:
                    d[p, q, r, t] = value
    return s, d


def acoustic_min(material: PointMaterial, F: np.ndarray,
                 directions: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """Smallest acoustic-tensor eigenvalue of an elastic ``material`` at ``F`` [MPa].

    Args:
        material: A point material (evaluated without plastic state).
        F: Deformation gradient (3 x 3); only ``C = F^T F`` reaches the kernel, and the
            result is objective, so ``F = sqrt(C)`` gives the same value.
        directions: Unit reference directions N (n x 3); default
            :func:`sphere_directions`.

    Returns:
        The smallest eigenvalue over the directions, and the direction that gives it.
    """
    dirs = sphere_directions() if directions is None else directions
    res = evaluate(material, (F.T @ F).reshape(1, 9))
    s, d = _tensors(res.S[0], res.D[0].reshape(6, 6))
    a = np.einsum("ik,JL->iJkL", np.eye(3), s) + np.einsum("iM,MJNL,kN->iJkL", F, d, F)
    q = np.einsum("iJkL,nJ,nL->nik", a, dirs, dirs)
    smallest = np.linalg.eigvalsh(q)[:, 0]
    k = int(np.argmin(smallest))
    return float(smallest[k]), dirs[k]
