"""Coefficients sampled once on a uniform grid, trigonometric interpolation elsewhere (:class:`SampledCoefficients`):
what makes the coefficients K, C, f of a :class:`~ked_linear.periodic.PeriodicSystem` cheap on the uniform grids the
periodic solve and the time steppers ask for."""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

from .periodic import Coefficients, _apply


class TrigInterpolant:
    """The trigonometric interpolant of samples (G, F) at theta_j = 2 pi j / G, G even: degree G/2, the
    Nyquist term a cosine, so that it reproduces the samples.  Held as the non-negative half of its spectrum,
    d_k = a_k for k = 0 .. G/2 with the constant and the Nyquist coefficient halved (values 2 Re sum_k d_k
    e^{i k theta}: the samples are real, a_-k = conj a_k), one real FFT of the samples; evaluated on a uniform
    full-turn grid by folding the spectrum and one inverse real FFT (O(G + m log m) per column)."""

    def __init__(self, samples: np.ndarray):
        G = samples.shape[0]
        if G % 2 or G < 2:
            raise ValueError(f"TrigInterpolant: needs an even number of samples >= 2; got {G}")
        d = np.fft.rfft(samples, axis=0).reshape(G // 2 + 1, -1) / G
        d[0] *= 0.5
        d[G // 2] *= 0.5
        # stored transposed, (F, G/2 + 1): the FFTs then run along contiguous rows
        self.spectrum = np.ascontiguousarray(d.T)
        self.frequency = np.arange(G // 2 + 1)
        self.points = G

    def uniform(self, theta0: float, step_sign: float, m: int) -> np.ndarray:
        """Values (m, F) at theta0 + step_sign * 2 pi j / m, j = 0 .. m - 1."""
        spec = self.spectrum
        F, width = spec.shape
        # values 2 Re sum_rho P_rho e^{2 pi i rho j / m}, P_rho the sum of the d_k e^{i k theta0} with k = rho
        # (mod m): the inverse real FFT of b_rho = P_rho + conj P_-rho, rho = 0 .. m/2
        n = m // 2 + 1
        full = width // m
        if full:
            # column k = j m + rho: e^{i k theta0} = e^{i j m theta0} e^{i rho theta0}, so the columns are
            # folded by residue with the first factor, the second applied after
            w = np.exp(1j * (m * theta0) * np.arange(full + 1))
            if full <= 4:  # a few slices (einsum costs more than their sum)
                P = spec[:, :m].copy()
                for j in range(1, full):
                    P += w[j] * spec[:, j * m:(j + 1) * m]
            else:
                P = np.einsum("j,fjm->fm", w[:full], spec[:, :full * m].reshape(F, full, m))
            P[:, :width - full * m] += w[full] * spec[:, full * m:]
            P *= np.exp(1j * theta0 * np.arange(m))
            b = P[:, :n].copy()
            b[:, 0] += np.conj(P[:, 0])
            b[:, 1:] += np.conj(P[:, m - 1:m - n:-1])  # P_-rho = P_{m - rho}, rho = 1 .. n - 1
        else:  # fewer frequencies than residues: P_rho = d_rho e^{i rho theta0} for rho < width, else 0
            b = np.zeros((F, n), dtype=complex)
            low = min(width, n)
            b[:, :low] = spec[:, :low] * np.exp(1j * theta0 * np.arange(low))
            b[:, 0] = 2.0 * spec[:, 0].real  # d_0 is real
            lo = max(m - width + 1, 1)  # the rho >= 1 with -rho = m - rho < width
            if lo < n:
                k = np.arange(m - lo, m - n, -1)
                b[:, lo:] += np.conj(spec[:, m - lo:m - n:-1] * np.exp(1j * theta0 * k))
        if step_sign < 0:
            np.conj(b, out=b)  # Re sum_rho b_rho e^{-i rho t} = Re sum_rho conj(b_rho) e^{i rho t}
        out = np.fft.irfft(b, n=m, axis=1) * m if m > 1 else b.real
        return out.T

    def grids(self, theta0: np.ndarray, step_sign: float, m: int) -> np.ndarray:
        """Values (g m, F) on the g uniform full-turn grids theta0[i] + step_sign * 2 pi j / m, grid by grid
        (the stage angles of a Runge-Kutta pass: one grid per stage)."""
        return np.concatenate([self.uniform(float(t), step_sign, m) for t in np.atleast_1d(theta0)])

    def at(self, theta: np.ndarray) -> np.ndarray:
        """Values (m, F) at any angles (m,), by direct summation (O(G m) per column)."""
        return 2.0 * (np.exp(1j * np.outer(theta, self.frequency)) @ self.spectrum.T).real

    def evaluate(self, theta: np.ndarray, index: np.ndarray | None = None) -> np.ndarray:
        """Values (m, F) at the angles ``theta`` (m,): by :meth:`uniform` on each uniform full-turn grid they
        consist of (``index``, default :func:`uniform_grids` of ``theta``), else by direct summation
        (:meth:`at`)."""
        index = uniform_grids(theta) if index is None else index
        if index is None:
            return self.at(theta)
        out = np.empty((theta.size, self.spectrum.shape[0]))
        for row in index:
            sign = 1.0 if theta[row[1]] > theta[row[0]] else -1.0
            out[row] = self.uniform(theta[row[0]], sign, row.size)
        return out


def midpoint_errors(flat: np.ndarray, fields: tuple[slice, ...]) -> np.ndarray:
    """Per field (``fields``: column slices of ``flat`` (G, F)), the largest error relative to the field's
    peak of the trigonometric interpolant of the even samples at the odd ones: an upper bound of the error
    of the interpolant of all samples (the series converging geometrically); inf where not finite."""
    half = _midpoint_values(flat[0::2])  # the odd samples are the even ones' midpoints
    err = np.zeros(len(fields))
    for i, f in enumerate(fields):
        peak = np.max(np.abs(flat[:, f]))
        if not np.isfinite(peak):  # NaN or inf samples: never interpolable
            err[i] = np.inf
        elif peak > 0.0:
            err[i] = np.max(np.abs(half[:, f] - flat[1::2, f])) / peak  # finite samples: never NaN
    return err


def uniform_grids(theta: np.ndarray, most: int = 4) -> np.ndarray | None:
    """If ``theta`` (m,) consists of r <= ``most`` uniform full-turn grids (theta0 + sign 2 pi j / (m/r),
    j = 0 .. m/r - 1), one after another or interleaved (the angles of a multi-stage time stepper), the
    index (r, m/r) of each grid's angles in ``theta``; else None."""
    m = theta.size
    for r in range(1, most + 1):
        if m % r or m // r < 2:
            continue
        for index in (np.arange(m).reshape(r, m // r), np.arange(m).reshape(m // r, r).T):
            d = np.diff(theta[index], axis=1)
            step = 2.0 * np.pi / index.shape[1]
            if np.all(np.abs(np.abs(d) - step) < 1e-9 * step) and np.all(np.sign(d) == np.sign(d[:, :1])):
                return index
    return None


INTERPOLATION_TOLERANCE = 1e-9
"""Largest error of interpolated coefficients, per field (K, C, f, output) as a fraction of its largest
entry over the cycle, measured at the midpoints of the sampling grid before it is refined once more."""


MAX_POINTS = 4096
"""Most samples kept by :class:`SampledCoefficients`, which doubles its grid up to this unless it passes
(or neither form is finite, or the interpolant would exceed :data:`SPECTRUM_BYTES`).  Their cost is one
frame condensation each, once per system; the alternative, direct evaluation at every angle asked for,
costs that at each of the thousands of stage angles of every propagator level.  On 8 generated atlas
linkages (every mechanism and mass model at r = 0.05 and 0.2), 22 of 128 systems (extender 14, tip 4,
distributed 4) fell back to direct evaluation under a rule that stopped at 512 samples or once the smaller of
the two forms' errors fell less than 100-fold per doubling: the compliance form, rebuilt into K, sits at a
rounding floor near 2e-9-1e-7 while the stiffness form is still converging, geometrically but slowly at
first (a stiffening support).  Now all 128 pass, 12 of them on 1024 to 4096 samples (tip, linkage 4,
cognate: 3.6e-4, 7e-8, 4.4e-13 on 1024, 2048, 4096)."""

SPECTRUM_BYTES = 16 * 2**20
"""The grid is not doubled past the number of samples whose interpolant (the non-negative half of the complex
spectrum of every kept column, G/2 + 1 frequencies) would exceed this: a 5-lump distributed model (1800
columns) stops at 1024 samples, where the surveyed ones passed (the interpolant of K and C alone, for a
propagator's stages, takes about as much again)."""

MEMO_ANGLES = 512
"""Requests of at most this many angles are remembered (the last 8): the collocation grids recur."""


class SampledCoefficients:
    """``direct`` (theta -> :class:`Coefficients`) sampled once on a uniform grid and interpolated
    trigonometrically on every uniform full-turn grid asked for (the collocation points of the periodic
    solve, the stage angles of a time stepper); non-uniform angles are evaluated by ``direct``.

    G doubles from ``start``: once the interpolant of G samples matches ``direct`` at the G midpoints
    within ``tolerance`` (:func:`_field_error`), the 2 G samples (grid and midpoints) are kept, so the
    interpolant is exact at them and, the series converging geometrically, far within ``tolerance``
    elsewhere.  Two forms are tried on the same samples: the coefficients themselves ("stiffness"), and
    the compliance form K^-1, K^-1 C K^-1, K^-1 f, output K^-1 ("flexibility", K etc. rebuilt per angle):
    the frozen structure's flexibility is smooth even where its stiffness spikes (a lumped mass whose
    flexibility nearly vanishes in one direction).  Neither passing below ``max_points`` (a kink, a linkage
    near toggle), ``direct`` is used everywhere (``form`` "direct").

    ``points``: the number of samples kept (0: direct); ``error``: the last measured midpoint error.
    The sampling is done at the first request (or when ``form``, ``points`` or ``error`` is read)."""

    def __init__(self, direct: Callable[[np.ndarray], Coefficients], tolerance: float = INTERPOLATION_TOLERANCE,
                 start: int = 32, max_points: int = MAX_POINTS):
        self.direct = direct
        self._options = (tolerance, start, max_points)
        self._sampled = False
        self._memo: dict[bytes, Coefficients] = {}
        self._kc: TrigInterpolant | None = None  # the interpolant of K and C alone (stiffness_damping)
        self._lock = threading.RLock()  # one object may serve several threads (solve_linear's recalled systems)

    form = property(lambda self: self._sample()._form)
    points = property(lambda self: self._sample()._points)
    error = property(lambda self: self._sample()._error)
    interpolant = property(lambda self: self._sample()._interpolant)

    def _sample(self) -> SampledCoefficients:
        if not self._sampled:
            with self._lock:  # another thread must not see a half-sampled object (form "direct" meanwhile)
                if not self._sampled:
                    self._form, self._points, self._error = "direct", 0, float("nan")
                    self._interpolant: TrigInterpolant | None = None
                    self._refine(*self._options)
                    self._sampled = True
        return self

    def _refine(self, tolerance: float, start: int, max_points: int) -> None:
        direct = self.direct
        G = start
        both = direct(np.arange(2 * G) * (np.pi / G))  # the first grid and its midpoints in one evaluation
        grid, mid = _every_other(both, 0), _every_other(both, 1)
        # which fields are symmetric (then interpolated by their triangles), per form: judged on the first
        # grid a form is tried on (the symmetry of K and C is structural), the coefficients' on both
        layout = tuple(f.shape[1:] for f in _fields(mid))
        exact_sym = _symmetric(both)
        bounds = _bounds(layout, exact_sym)
        symmetric: dict[str, tuple[bool, ...]] = {}
        while True:
            exact = _compact(mid, exact_sym)  # the errors are measured on the coefficients, by their triangles
            errors = {}
            for form in ("stiffness", "flexibility"):
                sampled = _to_form(form, grid)
                if form not in symmetric:
                    symmetric[form] = exact_sym if form == "stiffness" else _symmetric(sampled)
                sym = symmetric[form]
                values = _midpoint_values(_compact(sampled, sym))
                if form != "stiffness":
                    values = _compact(_from_form(form, _expand(values, layout, sym)), exact_sym)
                elif sym != exact_sym:
                    values = _compact(_expand(values, layout, sym), exact_sym)
                errors[form] = _compact_error(values, exact, bounds)
                if errors[form] <= tolerance:
                    self._form, self._points, self._error, self.layout, self.symmetric = form, 2 * G, errors[form], \
                        layout, sym
                    self._interpolant = TrigInterpolant(interleave(_compact(sampled, sym),
                                                                   _compact(_to_form(form, mid), sym)))
                    return
            self._error = min(errors.values(), key=lambda e: e if np.isfinite(e) else np.inf)
            # give up at max_points, at the interpolant's memory bound or when neither form gives finite
            # values; no earlier: a form may stay near O(1) for several doublings before its grid resolves a
            # spike and then converge fast (the tip model's stiffness form: 1.2, 1.1, 0.8, 0.14, 1.4e-2,
            # 4.5e-5, 4.3e-10 on a generated linkage), and the fallback, direct evaluation, costs a frame
            # condensation at every angle of every propagator level (thousands per level), against one per
            # sample here, once per system
            next_bytes = 2 * G * int(bounds[-1]) * np.dtype(complex).itemsize  # 4 G samples kept next
            if 4 * G > max_points or next_bytes > SPECTRUM_BYTES or not any(np.isfinite(e) for e in errors.values()):
                return
            grid, G = _merge(grid, mid), 2 * G
            mid = direct((np.arange(G) + 0.5) * (2.0 * np.pi / G))

    def __call__(self, theta: np.ndarray) -> Coefficients:
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        if theta.size > MEMO_ANGLES:  # a propagator's stage angles: large and not asked for twice
            return self._evaluate(theta)
        key = theta.tobytes()
        with self._lock:
            if key in self._memo:
                return self._memo[key]
        co = self._evaluate(theta)
        for f in _fields(co):  # shared by every caller asking for these angles: read-only
            f.flags.writeable = False
        with self._lock:
            if key not in self._memo:
                if len(self._memo) >= 8:  # bounded: the same angles recur (levels of the periodic solve)
                    self._memo.pop(next(iter(self._memo)))
                self._memo[key] = co
            return self._memo[key]

    def stiffness_damping(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """K and C (m, n, n) at the angles ``theta`` (m,): as ``self(theta)``, interpolating only these two
        fields on uniform grids (a time stepper's stage angles need no load or output); not remembered."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        index = None if self.interpolant is None else uniform_grids(theta)
        if index is None:
            co = self(theta) if theta.size <= MEMO_ANGLES else self._evaluate(theta)
            return co.stiffness, co.damping
        if self._kc is None:
            bounds = _bounds(self.layout, self.symmetric)
            self._kc = _sub_interpolant(self.interpolant, int(bounds[2]))
        flat = self._kc.evaluate(theta, index)
        K, C = _expand_fields(flat, self.layout[:2], self.symmetric[:2])
        if self.form == "stiffness":
            return K, C
        K = inverse(K)  # K from the flexibility F, C = K (F C F) K (as _from_form)
        K = 0.5 * (K + np.swapaxes(K, 1, 2))
        return K, K @ C @ K

    def _evaluate(self, theta: np.ndarray) -> Coefficients:
        index = None if self.interpolant is None else uniform_grids(theta)
        if index is None:
            return self.direct(theta)
        return _from_form(self.form, _expand(self.interpolant.evaluate(theta, index), self.layout, self.symmetric))


def _midpoint_values(samples: np.ndarray) -> np.ndarray:
    """The values (G, F) at the midpoints theta_j + pi / G of the :class:`TrigInterpolant` of ``samples``
    (G, F) at theta_j = 2 pi j / G: its Nyquist term vanishes there, so one real FFT, a phase shift and
    one inverse real FFT (the same series as ``TrigInterpolant(samples).uniform(pi / G, 1.0, G)``)."""
    G = samples.shape[0]
    X = np.fft.rfft(samples, axis=0)
    X *= np.exp(1j * (np.pi / G) * np.arange(X.shape[0]))[:, None]
    X[G // 2] = 0.0
    return np.fft.irfft(X, n=G, axis=0)


def _bounds(layout: tuple[tuple[int, ...], ...], symmetric: tuple[bool, ...]) -> np.ndarray:
    """The first column of each field in its :func:`_compact` array, then the total."""
    sizes = [shape[0] * (shape[0] + 1) // 2 if sym else int(np.prod(shape)) for shape, sym in zip(layout, symmetric)]
    return np.concatenate([[0], np.cumsum(sizes)]).astype(np.intp)


def _compact_error(approx: np.ndarray, exact: np.ndarray, bounds: np.ndarray) -> float:
    """:func:`_field_error` of :func:`_compact` arrays (a symmetric field by its triangle: the same maxima),
    the fields' columns starting at ``bounds`` (:func:`_bounds`)."""
    if not (np.all(np.isfinite(approx)) and np.all(np.isfinite(exact))):
        return float("nan")
    starts = bounds[:-1][np.diff(bounds) > 0]
    if starts.size == 0:
        return 0.0
    diff = np.maximum.reduceat(np.max(np.abs(approx - exact), axis=0), starts)
    peak = np.maximum.reduceat(np.max(np.abs(exact), axis=0), starts)
    some = peak > 0.0
    return float(np.max(diff[some] / peak[some], initial=0.0))


def inverse(Z: np.ndarray) -> np.ndarray:
    """Z^-1 of matrices (..., n, n): in closed form (adjugate over determinant) for n <= 2, where LAPACK's
    per-matrix call costs over ten times the arithmetic (a thesis tip model's 2 x 2 matrices at the
    thousand stage angles of a propagator level: 12 against 170 us), else numpy's LU inverse."""
    n = Z.shape[-1]
    if n == 1:
        return 1.0 / Z
    if n != 2:
        return np.linalg.inv(Z)
    a, b, c, d = Z[..., 0, 0], Z[..., 0, 1], Z[..., 1, 0], Z[..., 1, 1]
    with np.errstate(divide="ignore", invalid="ignore"):  # singular: inf/NaN, as the callers check
        r = 1.0 / (a * d - b * c)
    out = np.empty_like(Z)
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = d * r, -b * r, -c * r, a * r
    return out


def _every_other(co: Coefficients, first: int) -> Coefficients:
    return _coefficients([f[first::2] for f in _fields(co)])


def _merge(a: Coefficients, b: Coefficients) -> Coefficients:
    """Interleave the samples of ``a`` and ``b`` (a[0], b[0], a[1], ...)."""
    return _coefficients([interleave(fa, fb) for fa, fb in zip(_fields(a), _fields(b))])


def interleave(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rows of ``a`` and ``b`` (same shape) alternately: a[0], b[0], a[1], ... (samples on a grid and
    on its midpoints -> samples on the grid twice as fine)."""
    out = np.empty((2 * a.shape[0],) + a.shape[1:])
    out[0::2], out[1::2] = a, b
    return out


def _fields(co: Coefficients) -> list[np.ndarray]:
    return [co.stiffness, co.damping, co.load] + ([] if co.output is None else [co.output])


def _coefficients(fields: list[np.ndarray]) -> Coefficients:
    return Coefficients(*fields) if len(fields) == 4 else Coefficients(*fields, output=None)


def _to_form(form: str, co: Coefficients) -> Coefficients:
    """The sampled quantities of ``form``: the coefficients, or K^-1, K^-1 C K^-1, K^-1 f, output K^-1
    (the damping congruent with the flexibility: smooth where C spikes with K, e.g. C = beta K_E of a
    lump whose support stiffens 1000-fold within a few degrees near toggle, the thesis tip model)."""
    if form == "stiffness":
        return co
    F = inverse(co.stiffness)
    F = 0.5 * (F + np.swapaxes(F, 1, 2))
    return Coefficients(stiffness=F, damping=F @ co.damping @ F, load=_apply(F, co.load),
                        output=None if co.output is None else co.output @ F)


def _from_form(form: str, co: Coefficients) -> Coefficients:
    """The coefficients from the quantities of ``form``: the same map (its own inverse: K = F^-1, K (F C F) K = C,
    K (F f) = f, (output F) K = output)."""
    return _to_form(form, co)


def _symmetric(co: Coefficients) -> tuple[bool, ...]:
    """Per field: square and symmetric to rounding (then only its upper triangle is interpolated)."""
    out = []
    for f in _fields(co):
        square = f.ndim == 3 and f.shape[1] == f.shape[2]
        out.append(bool(square and np.max(np.abs(f - np.swapaxes(f, 1, 2)), initial=0.0)
                        <= 1e-13 * np.max(np.abs(f), initial=0.0)))
    return tuple(out)


def _compact(co: Coefficients, symmetric: tuple[bool, ...]) -> np.ndarray:
    """Like :func:`_pack`, the symmetric fields by their upper triangles."""
    parts = []
    for f, sym in zip(_fields(co), symmetric):
        parts.append(f.reshape(f.shape[0], -1)[:, _upper_flat(f.shape[1])] if sym else f.reshape(f.shape[0], -1))
    return np.concatenate(parts, axis=1)


def _sub_interpolant(interpolant: TrigInterpolant, columns: int) -> TrigInterpolant:
    """The interpolant of the first ``columns`` columns of ``interpolant``'s samples (its spectrum's rows)."""
    sub = object.__new__(TrigInterpolant)
    sub.spectrum = np.ascontiguousarray(interpolant.spectrum[:columns])
    sub.frequency, sub.points = interpolant.frequency, interpolant.points
    return sub


def _expand(flat: np.ndarray, layout: tuple[tuple[int, ...], ...], symmetric: tuple[bool, ...]) -> Coefficients:
    """Inverse of :func:`_compact` (a symmetric field by one gather of its triangle's columns)."""
    return _coefficients(_expand_fields(flat, layout, symmetric))


def _expand_fields(flat: np.ndarray, layout: tuple[tuple[int, ...], ...],
                   symmetric: tuple[bool, ...]) -> list[np.ndarray]:
    """The fields of ``layout`` from the leading columns of a :func:`_compact` array."""
    parts, start, m = [], 0, flat.shape[0]
    for shape, sym in zip(layout, symmetric):
        if sym:
            index = _triangle_index(shape[0])
            parts.append(np.take(flat[:, start:start + index.max() + 1], index, axis=1).reshape((m,) + shape))
            start += shape[0] * (shape[0] + 1) // 2
        else:
            size = int(np.prod(shape))
            parts.append(flat[:, start:start + size].reshape((m,) + shape))
            start += size
    return parts


_TRIANGLES: dict[int, np.ndarray] = {}


_UPPER: dict[int, np.ndarray] = {}


def _upper_flat(n: int) -> np.ndarray:
    """The row-major flat indices of ``np.triu_indices(n)`` in an n x n matrix (cached: built per call, they
    cost more than the gather itself for the small matrices of a linkage)."""
    if n not in _UPPER:
        i, j = np.triu_indices(n)
        _UPPER[n] = i * n + j
    return _UPPER[n]


def _triangle_index(n: int) -> np.ndarray:
    """For each entry (i, j) of an n x n matrix, row-major, its column in the upper triangle's list
    ``np.triu_indices(n)`` (of (min, max))."""
    if n not in _TRIANGLES:
        i, j = np.triu_indices(n)
        where = np.empty((n, n), dtype=np.intp)
        where[i, j] = where[j, i] = np.arange(i.size)
        _TRIANGLES[n] = where.ravel()
    return _TRIANGLES[n]


def _pack(co: Coefficients) -> tuple[np.ndarray, tuple[tuple[int, ...], ...]]:
    """The fields of ``co`` side by side, (m, F), and their shapes (without m)."""
    fields = _fields(co)
    m = fields[0].shape[0]
    return np.concatenate([f.reshape(m, -1) for f in fields], axis=1), tuple(f.shape[1:] for f in fields)


def _field_error(approx: np.ndarray, exact: np.ndarray, layout: tuple[tuple[int, ...], ...]) -> float:
    """max over the fields of max |approx - exact| / max |exact| (NaN if anything is not finite)."""
    err, start = 0.0, 0
    for shape in layout:
        sl = slice(start, start + int(np.prod(shape)))
        start = sl.stop
        peak = np.max(np.abs(exact[:, sl]), initial=0.0)
        if peak > 0.0:
            err = max(err, float(np.max(np.abs(approx[:, sl] - exact[:, sl])) / peak))
    return err if np.all(np.isfinite(approx)) and np.all(np.isfinite(exact)) else float("nan")
