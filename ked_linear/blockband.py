"""LU factors of a block-banded matrix, for the preconditioner of the iterative periodic solve.

Why not ``scipy.sparse.linalg.splu``: the factors are the same kind (Gaussian elimination in the natural
order keeps the fill inside the band), but importing ``scipy.sparse`` (scipy clones numpy's namespace for
the array API) costs a fresh ``ked check`` process about 0.3 s, as long as the rest of a one-speed check.
"""

from __future__ import annotations

import numpy as np

PIVOT_LIMIT = 1e12
"""Largest |pivot block inverse| times the band's largest |entry| the factors accept (see
:class:`BlockBandedLU`)."""

GROUP_WIDTH = 48
"""Blocks smaller than this are grouped into blocks of about this size (:func:`regroup`): the substitutions
loop over the blocks in Python, and on small blocks the loop's overhead, not the arithmetic, is the cost."""


class BlockBandedLU:
    """Block LU of A ((m n) x (m n)): m block rows of n, blocks A[k, l] nonzero only for |k - l| <= b.

    ``band`` (m, 2 b + 1, n, n): band[k, b + d] = A[k, k + d] (entries outside the matrix ignored).
    Block Gaussian elimination in order: each pivot block is inverted (LAPACK, partial pivoting inside it),
    no pivoting between blocks: fit for matrices whose diagonal blocks dominate their rows, as the
    collocation operator's do (each is a damped dynamic stiffness; :func:`ked_linear.periodic._solve_krylov`
    uses these factors only as a preconditioner).  Blocks under :data:`GROUP_WIDTH` are grouped first.
    Raises ``numpy.linalg.LinAlgError`` when a pivot block is singular or nearly so (its inverse over
    :data:`PIVOT_LIMIT` times the reciprocal of the matrix's largest entry: pivoting between blocks would be
    needed) or the factors are not finite."""

    def __init__(self, band: np.ndarray):
        self.size = band.shape[0] * band.shape[2]
        band = regroup(band, max(1, GROUP_WIDTH // band.shape[2]))
        m, w, n, _ = band.shape
        b = (w - 1) // 2
        self.m, self.b, self.n = m, b, n
        A = np.array(band, dtype=np.result_type(band.dtype, np.float64))  # (k, b + d): eliminated in place
        for k in range(m):  # the entries outside the matrix are zero blocks
            A[k, :max(0, b - k)] = 0.0
            A[k, b + max(0, m - k):] = 0.0
        scale = np.max(np.abs(A))
        inv = np.empty((m, n, n), dtype=A.dtype)
        low = np.zeros((m, b, n, n), dtype=A.dtype)  # low[k, b - i] = L[k, k - i]
        for k in range(m):
            inv[k] = np.linalg.inv(A[k, b])
            i = np.arange(1, min(b, m - 1 - k) + 1)  # L[k + i, k] sits at A[k + i, b - i]
            if i.size == 0:
                continue
            L = A[k + i, b - i] @ inv[k]  # (p, n, n)
            low[k + i, b - i] = L
            # A[k + i, k + j] -= L[k + i, k] A[k, k + j], j = 1 .. b (those inside the matrix)
            A[(k + i)[:, None], (b - i)[:, None] + i[None, :]] -= L[:, None] @ A[k, b + i][None]
        # backward substitution with the pivot inverses folded in: x_k = inv_k y_k - upper_k [x_k+1 .. x_k+b]
        up = np.zeros((m, b, n, n), dtype=A.dtype)  # up[k, d - 1] = inv_k A[k, k + d]
        for d in range(1, min(b, m - 1) + 1):
            up[:m - d, d - 1] = inv[:m - d] @ A[:m - d, b + d]
        if np.max(np.abs(inv)) * scale > PIVOT_LIMIT:
            raise np.linalg.LinAlgError("block-banded LU: a pivot block is nearly singular")
        self._inv = inv
        self._lower = np.ascontiguousarray(low.transpose(0, 2, 1, 3)).reshape(m, n, b * n)  # [L[k, k-b] ..]
        self._upper = np.ascontiguousarray(up.transpose(0, 2, 1, 3)).reshape(m, n, b * n)  # [.. U[k, k+b]]
        if not all(np.all(np.isfinite(a)) for a in (self._inv, self._lower, self._upper)):
            raise np.linalg.LinAlgError("block-banded factors not finite")

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """A^-1 rhs for one right-hand side (m n,)."""
        m, b, n = self.m, self.b, self.n
        y = np.zeros((m + b, n), dtype=np.result_type(self._inv, rhs))  # b leading zero blocks
        y.reshape(-1)[b * n:b * n + self.size] = rhs  # blocks added by grouping: zero rows
        flat = y.reshape(-1)
        for k in range(m):  # y_k -= sum_i L[k, k - i] y_k-i
            y[b + k] -= self._lower[k] @ flat[k * n:(k + b) * n]
        x = np.zeros((m + b, n), dtype=y.dtype)  # b trailing zero blocks
        x[:m] = (self._inv @ y[b:, :, None])[..., 0]
        flat = x.reshape(-1)
        for k in range(m - 2, -1, -1):
            x[k] -= self._upper[k] @ flat[(k + 1) * n:(k + 1 + b) * n]
        return flat[:self.size].copy()


def regroup(band: np.ndarray, g: int) -> np.ndarray:
    """The band (m, 2 b + 1, n, n) of :class:`BlockBandedLU` as one of blocks of g n (g consecutive block
    rows and columns each; the last group filled with identity blocks, coupled to nothing): bandwidth
    ceil(b / g).  The same matrix, bordered by an identity."""
    m, w, n, _ = band.shape
    b = (w - 1) // 2
    g = min(g, m)
    if g <= 1:
        return band
    mg, bg = -(-m // g), -(-b // g)
    out = np.zeros((mg, 2 * bg + 1, g * n, g * n), dtype=band.dtype)
    for k in range(mg * g):
        K, p = divmod(k, g)
        if k >= m:  # the border: identity
            out[K, bg, p * n:(p + 1) * n, p * n:(p + 1) * n] = np.eye(n)
            continue
        for d in range(-b, b + 1):
            l = k + d
            if 0 <= l < m:
                Lg, q = divmod(l, g)
                out[K, bg + Lg - K, p * n:(p + 1) * n, q * n:(q + 1) * n] = band[k, b + d]
    return out
