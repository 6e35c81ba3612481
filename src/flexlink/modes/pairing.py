"""Modes of two assumed-mode bases of the same mechanism paired by shape.

A mode's shape is its links' deflections w = Φq: each link's modal coordinates q through the
Cholesky factor R of its ∫ΦᵀΦ dm (tip body included, RᵀR = ∫ΦᵀΦ dm), so that the vector's
squared length is Σ ∫w² dm. A coarser basis's shape functions are the leading ones of a finer
(each kind's shapes do not depend on the count), so both are laid out alike with a fixed
width per link. Pairs are the one-to-one assignment of largest total MAC (modal assurance
criterion |aᴴb|²/(|a|²|b|²)). Joint, base and cart coordinates are left out: in an
oscillatory mode they follow the deflections (momentum), and a free base's are
ill-determined in the eigenvectors (an O(1) translation against deflections of 1e-8 in the
modes of a satellite that bend its two arrays alike).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .integrals import ModalData


def deflection_vectors(modal: Sequence[ModalData], q: Sequence[np.ndarray],
                       widths: Sequence[int]) -> np.ndarray:
    """(N, Σ widths) shape vectors of N modes: ``q[k]`` (n_k, N) the modal coordinates of
    link k in them (n_k = 0: a rigid link), ``widths[k]`` ≥ n_k its entries (zeros past n_k)."""
    count = next((block.shape[1] for block in q if block.ndim == 2 and block.shape[0]), 0)
    dtype = np.result_type(*[block.dtype for block in q], float)
    out = np.zeros((count, sum(widths)), dtype=dtype)
    start = 0
    for data, block, width in zip(modal, q, widths):
        if data.n and block.shape[0]:
            factor = np.linalg.cholesky(data.clamped_mass_matrix).T  # RᵀR = ∫ΦᵀΦ dm
            out[:, start:start + data.n] = (factor @ block).T
        start += width
    return out


def pair(coarse: np.ndarray, fine: np.ndarray) -> np.ndarray:
    """For each coarse mode's shape vector (rows of ``coarse``, (N, d)), the index of the fine
    mode (rows of ``fine``, (N', d), N' ≥ N) with its shape: the one-to-one assignment of
    largest total MAC. Without coordinates (d = 0: no elastic link) the ranks."""
    from scipy.optimize import linear_sum_assignment

    if not coarse.shape[1]:
        return np.arange(len(coarse))
    a = coarse / np.maximum(np.linalg.norm(coarse, axis=1, keepdims=True), 1e-300)
    b = fine / np.maximum(np.linalg.norm(fine, axis=1, keepdims=True), 1e-300)
    mac = np.abs(a.conj() @ b.T) ** 2
    rows, cols = linear_sum_assignment(mac, maximize=True)
    return cols[np.argsort(rows)]
