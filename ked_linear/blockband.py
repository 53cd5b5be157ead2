"""LU factors of a block-banded matrix, for the preconditioner of the iterative periodic solve.

Why not ``scipy.sparse.linalg.splu``: the factors are the same kind (Gaussian elimination in the natural
order keeps the fill inside the band), but importing ``scipy.sparse`` (scipy clones numpy's namespace for
the array API) costs a fresh ``ked check`` process about 0.3 s, as long as the rest of a one-speed check.
"""

from __future__ import annotations

import numpy as np


class BlockBandedLU:
    """Block LU of A ((m n) x (m n)): m block rows of n, blocks A[k, l] nonzero only for |k - l| <= b.

    ``band`` (m, 2 b + 1, n, n): band[k, b + d] = A[k, k + d] (entries outside the matrix ignored).
    Block Gaussian elimination in order: each pivot block is inverted (LAPACK, partial pivoting inside it),
    no pivoting between blocks: fit for matrices whose diagonal blocks dominate their rows, as the
    collocation operator's do (each is a damped dynamic stiffness; :func:`ked_linear.periodic._solve_krylov`
    uses these factors only as a preconditioner).  Raises ``numpy.linalg.LinAlgError`` when a pivot block
    is singular or the factors are not finite."""

    def __init__(self, band: np.ndarray):
        m, w, n, _ = band.shape
        b = (w - 1) // 2
        self.m, self.b, self.n = m, b, n
        A = np.array(band)  # (k, b + d): eliminated in place
        for k in range(m):  # the entries outside the matrix are zero blocks
            A[k, :max(0, b - k)] = 0.0
            A[k, b + max(0, m - k):] = 0.0
        inv = np.empty((m, n, n), dtype=A.dtype)
        lower = np.zeros((m, n, b * n), dtype=A.dtype)  # row k: [L[k, k - b] ... L[k, k - 1]]
        for k in range(m):
            inv[k] = np.linalg.inv(A[k, b])
            rows = np.arange(k + 1, min(k + b, m - 1) + 1)
            if rows.size == 0:
                continue
            i = rows - k  # L[k + i, k] sits at A[k + i, b - i]
            L = A[rows, b - i] @ inv[k]  # (p, n, n)
            for p, ip in enumerate(i):
                lower[k + ip][:, (b - ip) * n:(b - ip + 1) * n] = L[p]
            j = np.arange(1, min(b, m - 1 - k) + 1)  # A[k + i, k + j] -= L[k + i, k] A[k, k + j]
            A[rows[:, None], (b - i)[:, None] + j[None, :]] -= L[:, None] @ A[k, b + j][None]
        # backward substitution with the pivot inverses folded in: x_k = inv_k y_k - upper_k [x_k+1 .. x_k+b]
        upper = np.zeros((m, n, b * n), dtype=A.dtype)
        for k in range(m):
            for d in range(1, min(b, m - 1 - k) + 1):
                upper[k][:, (d - 1) * n:d * n] = inv[k] @ A[k, b + d]
        if not (np.all(np.isfinite(inv)) and np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
            raise np.linalg.LinAlgError("block-banded factors not finite")
        self._inv, self._lower, self._upper = inv, lower, upper

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """A^-1 rhs for one right-hand side (m n,)."""
        m, b, n = self.m, self.b, self.n
        y = np.zeros((m + b, n), dtype=np.result_type(self._inv, rhs))  # b leading zero blocks
        y[b:] = rhs.reshape(m, n)
        flat = y.reshape(-1)
        for k in range(m):  # y_k -= sum_i L[k, k - i] y_k-i
            y[b + k] -= self._lower[k] @ flat[k * n:(k + b) * n]
        x = np.zeros((m + b, n), dtype=y.dtype)  # b trailing zero blocks
        x[:m] = (self._inv @ y[b:, :, None])[..., 0]
        flat = x.reshape(-1)
        for k in range(m - 2, -1, -1):
            x[k] -= self._upper[k] @ flat[(k + 1) * n:(k + 1 + b) * n]
        return x[:m].reshape(-1)
