"""Machine-code kernels of the compiled engine (numba); imported only when that engine runs.

See :mod:`scara_robust.simulation.compiled` for what they integrate and how. The layout
of the packed parameter vector θ is defined there and repeated here as constants.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from .loop import STATE_LIMIT

__all__ = ["run", "refine", "batch", "torque", "rhs", "segment"]

Array = NDArray[np.float64]

_ROBOT, _PAYLOAD, _REF, _DIST, _KIND, _K, _SMC, _SMC_ROBOT, _LIMIT, _TS = 0, 9, 13, 15, 20, 21, 33, 37, 46, 48
_COMPLETED, _DIVERGED, _FAILED = 0, 1, 2

jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: Small kernels are inlined into the integrator's stages.
inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")


@inline
def mass_terms(rb: Array, off: int, c2: float, s2: float, w1: float, w2: float,
               mp: float) -> tuple[float, float, float, float, float]:
    """M11, M12, M22 (kg·m²) and C1, C2 (N·m) of robot parameters rb[off:off+9], from cos q2 and sin q2."""
    m1, m2, L1, L2, Lc1, Lc2, I1, I2, cp = (rb[off], rb[off + 1], rb[off + 2], rb[off + 3], rb[off + 4],
                                            rb[off + 5], rb[off + 6], rb[off + 7], rb[off + 8])
    a1 = m1 * Lc1**2 + (m2 + mp) * L1**2 + I1
    a2 = m2 * Lc2**2 + mp * L2**2 + I2 + cp * mp
    a3 = L1 * (m2 * Lc2 + mp * L2)
    return a1 + a2 + 2 * a3 * c2, a2 + a3 * c2, a2, -a3 * (2 * w1 * w2 + w2 * w2) * s2, a3 * w1 * w1 * s2


@inline
def payload(th: Array, t: float) -> float:
    if th[_PAYLOAD + 1] == 0.0:  # a constant payload: the same number without the sine
        return float(th[_PAYLOAD])
    return float(th[_PAYLOAD] + th[_PAYLOAD + 1] * math.sin(th[_PAYLOAD + 2] * t + th[_PAYLOAD + 3]))


@inline
def disturbance_level(th: Array, t: float) -> float:
    frac = t / th[_DIST + 1] + th[_DIST + 2] / (2 * math.pi)
    frac = frac - math.floor(frac)
    return 1.0 if frac < 0.5 else -1.0


# The kernels below take sin ωt, cos ωt (reference) and cos q2, sin q2 from their caller, so
# one right-hand side evaluates each sine once: these calls are most of its cost.
@inline
def torque_sc(th: Array, sw: float, cw: float, c2: float, s2: float, x: Array, out: Array) -> None:
    a, w = th[_REF], th[_REF + 1]
    r1, r2 = a * sw, a * cw
    v1, v2 = a * w * cw, -a * w * sw
    e1, e2 = r1 - x[0], r2 - x[1]
    d1, d2 = v1 - x[2], v2 - x[3]
    kind = th[_KIND]
    if kind == 0:
        k = th[_K:_K + 12]
        u1 = -(k[0] * x[4] + k[1] * x[5] + k[2] * e1 + k[3] * e2 + k[4] * d1 + k[5] * d2)
        u2 = -(k[6] * x[4] + k[7] * x[5] + k[8] * e1 + k[9] * e2 + k[10] * d1 + k[11] * d2)
    else:
        lam, kd, ks, phi = th[_SMC], th[_SMC + 1], th[_SMC + 2], th[_SMC + 3]
        s1, s2_ = d1 + lam * e1, d2 + lam * e2
        acc1, acc2 = -w * w * r1 + lam * d1, -w * w * r2 + lam * d2
        m11, m12, m22, c1, c2_ = mass_terms(th, _SMC_ROBOT, c2, s2, x[2], x[3], 0.0)
        if kind == 1:
            g1 = min(max(s1 / phi, -1.0), 1.0)
            g2 = min(max(s2_ / phi, -1.0), 1.0)
        else:
            g1 = (s1 > 0) - (s1 < 0) * 1.0
            g2 = (s2_ > 0) - (s2_ < 0) * 1.0
        u1 = m11 * acc1 + m12 * acc2 + c1 + kd * s1 + ks * g1
        u2 = m12 * acc1 + m22 * acc2 + c2_ + kd * s2_ + ks * g2
    lim1, lim2 = th[_LIMIT], th[_LIMIT + 1]
    out[0] = min(max(u1, -lim1), lim1)
    out[1] = min(max(u2, -lim2), lim2)


@inline
def torque(th: Array, t: float, x: Array, out: Array) -> None:
    w = th[_REF + 1]
    torque_sc(th, math.sin(w * t), math.cos(w * t), math.cos(x[1]), math.sin(x[1]), x, out)


@inline
def rhs_sc(th: Array, t: float, sw: float, cw: float, c2: float, s2: float, x: Array, tc: Array, td: float,
           dx: Array) -> None:
    n = x.shape[0]
    big = 0.0
    for i in range(4):
        v = abs(x[i])
        if not v <= STATE_LIMIT:
            big = np.inf
    if big > 0:
        for i in range(n):
            dx[i] = 0.0
        return
    m11, m12, m22, c1, c2_ = mass_terms(th, _ROBOT, c2, s2, x[2], x[3], payload(th, t))
    b1 = tc[0] + td * th[_DIST + 3] - c1
    b2 = tc[1] + td * th[_DIST + 4] - c2_
    det = m11 * m22 - m12 * m12
    dx[0] = x[2]
    dx[1] = x[3]
    dx[2] = (m22 * b1 - m12 * b2) / det
    dx[3] = (m11 * b2 - m12 * b1) / det
    if n > 4:
        a = th[_REF]
        dx[4] = a * sw - x[0]
        dx[5] = a * cw - x[1]


@inline
def rhs(th: Array, t: float, x: Array, tc: Array, td: float, dx: Array) -> None:
    sw = cw = 0.0
    if x.shape[0] > 4:
        w = th[_REF + 1]
        sw, cw = math.sin(w * t), math.cos(w * t)
    rhs_sc(th, t, sw, cw, math.cos(x[1]), math.sin(x[1]), x, tc, td, dx)


@inline
def closed_rhs(th: Array, t: float, x: Array, td: float, tc: Array, dx: Array) -> None:
    w = th[_REF + 1]
    sw, cw = math.sin(w * t), math.cos(w * t)
    c2, s2 = math.cos(x[1]), math.sin(x[1])
    torque_sc(th, sw, cw, c2, s2, x, tc)
    rhs_sc(th, t, sw, cw, c2, s2, x, tc, td, dx)

@jit
def closed_rhs_call(th: Array, t: float, x: Array, td: float, tc: Array, dx: Array) -> None:
    """:func:`closed_rhs` as a called function, where a call costs little: it bounds the compile time."""
    closed_rhs(th, t, x, td, tc, dx)


@inline
def output(th: Array, t: float, x: Array, tc: Array, TC: Array, ER: Array, j: int) -> None:
    """Sample j: torque TC[:, j] (N·m) and errors ER[:, j] = (r - q, ṙ - q̇) (rad, rad/s) at state x."""
    a, w = th[_REF], th[_REF + 1]
    sw, cw = math.sin(w * t), math.cos(w * t)
    torque_sc(th, sw, cw, math.cos(x[1]), math.sin(x[1]), x, tc)
    TC[0, j], TC[1, j] = tc[0], tc[1]
    ER[0, j] = a * sw - x[0]
    ER[1, j] = a * cw - x[1]
    ER[2, j] = a * w * cw - x[2]
    ER[3, j] = -a * w * sw - x[3]

# Dormand–Prince 5(4) tableau
c = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
A = np.zeros((7, 6))
A[1, 0] = 1 / 5
A[2, :2] = (3 / 40, 9 / 40)
A[3, :3] = (44 / 45, -56 / 15, 32 / 9)
A[4, :4] = (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729)
A[5, :5] = (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656)
A[6, :6] = (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84)
# scipy's RK45 dense output (Shampine's quartic): y(t + θh) = y + h Σ_s K_s (P_s · [θ, θ², θ³, θ⁴])
P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])
E = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])

@jit
def dopri_interval(th: Array, x: Array, t0: float, t1: float, td: float, h0: float, rtol: float,
                   atol: float, K: Array, y: Array, tc: Array) -> tuple[float, bool, int]:
    """Advance x in place from t0 to t1 exactly; returns (last accepted step, ok, rhs calls)."""
    n = x.shape[0]
    t = t0
    h = min(h0, t1 - t0)
    calls = 0
    closed_rhs_call(th, t, x, td, tc, K[0])
    calls += 1
    while t < t1:
        if t + h >= t1 or t1 - (t + h) < 1e-12 * max(1.0, abs(t1)):
            h = t1 - t
        for s in range(1, 7):
            for i in range(n):
                acc = x[i]
                for j in range(s):
                    acc += h * A[s, j] * K[j, i]
                y[i] = acc
            closed_rhs_call(th, t + c[s] * h, y, td, tc, K[s])
            calls += 1
        err = 0.0
        for i in range(n):
            sc = atol + rtol * max(abs(x[i]), abs(y[i]))
            ei = 0.0
            for j in range(7):
                ei += E[j] * K[j, i]
            ei *= h / sc
            err += ei * ei
        err = math.sqrt(err / n)
        if err <= 1.0 or not err == err:
            if not err == err:
                return h, False, calls
            t_new = t + h
            for i in range(n):
                x[i] = y[i]
                K[0, i] = K[6, i]  # first same as last
            t = t1 if h == t1 - t else t_new
            fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** -0.2))
            h_next = h * fac
            if t < t1:
                h = h_next
            else:
                return h_next, True, calls
        else:
            h = h * max(0.2, 0.9 * err ** -0.2)
            if h < 1e-14 * max(1.0, abs(t)):
                return h, False, calls
    return h, True, calls

@jit
def dopri_dense(th: Array, x: Array, a: float, b: float, td: float, h: float, rtol: float, atol: float,
                K: Array, y: Array, tc: Array, t_out: Array, j: int, X: Array,
                TC: Array, ER: Array) -> tuple[int, float, float, bool, int]:
    """Advance x in place from a to b with natural steps, writing outputs t_out[j:] in (a, b] by dense output.

    Returns (next output index, time reached, next step, ok, rhs calls).
    """
    n = x.shape[0]
    t = a
    calls = 1
    closed_rhs(th, t, x, td, tc, K[0])
    while t < b:
        hh = h
        if t + hh >= b or b - (t + hh) < 1e-12 * max(1.0, abs(b)):
            hh = b - t
        for s in range(1, 7):
            for i in range(n):
                acc = x[i]
                for q in range(s):
                    acc += hh * A[s, q] * K[q, i]
                y[i] = acc
            closed_rhs(th, t + c[s] * hh, y, td, tc, K[s])
            calls += 1
        err = 0.0
        for i in range(n):
            sc = atol + rtol * max(abs(x[i]), abs(y[i]))
            ei = 0.0
            for q in range(7):
                ei += E[q] * K[q, i]
            ei *= hh / sc
            err += ei * ei
        err = math.sqrt(err / n)
        if not err == err:
            return j, t, hh, False, calls
        if err <= 1.0:
            t_new = b if hh == b - t else t + hh
            while j < t_out.shape[0] and t_out[j] <= t_new + 1e-12:
                if t_out[j] >= t_new - 1e-15:
                    for i in range(n):
                        X[i, j] = y[i]
                else:
                    th1 = (t_out[j] - t) / hh
                    th2 = th1 * th1
                    th3 = th2 * th1
                    th4 = th3 * th1
                    for i in range(n):
                        acc = 0.0
                        for q in range(7):
                            acc += K[q, i] * (P[q, 0] * th1 + P[q, 1] * th2 + P[q, 2] * th3 + P[q, 3] * th4)
                        X[i, j] = x[i] + hh * acc
                output(th, t_out[j], X[:, j], tc, TC, ER, j)
                j += 1
            for i in range(n):
                x[i] = y[i]
                K[0, i] = K[6, i]  # first same as last
            t = t_new
            h = hh * (5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** -0.2)))
        else:
            h = hh * max(0.2, 0.9 * err ** -0.2)
            if h < 1e-14 * max(1.0, abs(t)):
                return j, t, h, False, calls
    return j, t, h, True, calls



# Variable-order BDF in the NDF form with a quasi-constant step: the method of
# scipy.integrate.BDF (Shampine & Reichelt 1997, "The MATLAB ODE suite"), step for step,
# with a forward-difference Jacobian. The stiff closed loop (a pole near -1500 1/s) holds an
# explicit method to its stability limit; this one takes the steps accuracy needs.
_MAX_ORDER = 5
_NEWTON_MAXITER = 4
_EPS = float(np.finfo(np.float64).eps)
_KAPPA = np.array([0.0, -0.1850, -1 / 9, -0.0823, -0.0415, 0.0])
_GAMMA = np.concatenate((np.zeros(1), np.cumsum(1 / np.arange(1, _MAX_ORDER + 1))))
_ALPHA = (1 - _KAPPA) * _GAMMA
_ERROR_CONST = _KAPPA * _GAMMA + 1 / np.arange(1, _MAX_ORDER + 2)


@inline
def rms_scaled(v: Array, scale: Array) -> float:
    acc = 0.0
    for i in range(v.shape[0]):
        q = v[i] / scale[i]
        acc += q * q
    return math.sqrt(acc / v.shape[0])


@jit
def change_D(D: Array, order: int, factor: float, work: Array) -> None:
    """Rescale the difference array D to a step `factor` times the current one (scipy's change_D).

    `work` is scratch of shape (4, MAX_ORDER + 1, max(MAX_ORDER + 1, n)).
    """
    m = order + 1
    R, U, RU, new = work[0], work[1], work[2], work[3]
    for col in range(m):
        R[0, col] = 1.0
        U[0, col] = 1.0
    for i in range(1, m):
        R[i, 0] = 0.0
        U[i, 0] = 0.0
        for col in range(1, m):
            R[i, col] = R[i - 1, col] * (i - 1 - factor * col) / i
            U[i, col] = U[i - 1, col] * (i - 1 - 1.0 * col) / i
    for i in range(m):
        for col in range(m):
            acc = 0.0
            for k in range(m):
                acc += R[i, k] * U[k, col]
            RU[i, col] = acc
    n = D.shape[1]
    for i in range(m):
        for q in range(n):
            acc = 0.0
            for k in range(m):
                acc += RU[k, i] * D[k, q]
            new[i, q] = acc
    for i in range(m):
        for q in range(n):
            D[i, q] = new[i, q]


@jit
def lu_factor(A: Array, piv: NDArray[np.int64]) -> None:
    """In-place LU with partial pivoting of a small dense matrix."""
    n = A.shape[0]
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        piv[k] = p
        if p != k:
            for q in range(n):
                A[k, q], A[p, q] = A[p, q], A[k, q]
        if A[k, k] != 0.0:
            for i in range(k + 1, n):
                A[i, k] /= A[k, k]
                for q in range(k + 1, n):
                    A[i, q] -= A[i, k] * A[k, q]


@inline
def lu_solve(LU: Array, piv: NDArray[np.int64], b: Array) -> None:
    n = LU.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        acc = b[i]
        for q in range(i):
            acc -= LU[i, q] * b[q]
        b[i] = acc
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for q in range(i + 1, n):
            acc -= LU[i, q] * b[q]
        b[i] = acc / LU[i, i]


@jit
def jacobian(th: Array, t: float, y: Array, f: Array, td: float, tc: Array, J: Array, w: Array,
             fw: Array) -> None:
    """Forward differences: J[:, k] = (f(y + h e_k) - f(y)) / h, h = sqrt(eps) max(1, |y_k|)."""
    n = y.shape[0]
    for k in range(n):
        for i in range(n):
            w[i] = y[i]
        h = math.sqrt(_EPS) * max(1.0, abs(y[k]))
        w[k] = y[k] + h
        h = w[k] - y[k]
        closed_rhs_call(th, t, w, td, tc, fw)
        for i in range(n):
            J[i, k] = (fw[i] - f[i]) / h


@jit
def bdf_dense(th: Array, x: Array, a: float, b: float, td: float, rtol: float, atol: float, tc: Array,
              t_out: Array, j: int, X: Array, TC: Array, ER: Array) -> tuple[int, float, bool, int]:
    """Advance x in place from a to b (one solve of scipy's BDF), writing outputs t_out[j:] in (a, b].

    Returns (next output index, time reached, ok, rhs calls).
    """
    n = x.shape[0]
    f0 = np.empty(n)
    w = np.empty(n)
    fw = np.empty(n)
    scale = np.empty(n)
    ypred = np.empty(n)
    psi = np.empty(n)
    y = np.empty(n)
    d = np.empty(n)
    dy = np.empty(n)
    J = np.empty((n, n))
    LU = np.empty((n, n))
    piv = np.zeros(n, np.int64)
    D = np.zeros((_MAX_ORDER + 3, n))
    work = np.zeros((4, _MAX_ORDER + 1, max(_MAX_ORDER + 1, n)))
    calls = 0
    t = a
    closed_rhs_call(th, t, x, td, tc, f0)
    calls += 1
    # initial step: scipy's select_initial_step with order 1
    interval = b - a
    for i in range(n):
        scale[i] = atol + abs(x[i]) * rtol
    d0 = rms_scaled(x, scale)
    d1 = rms_scaled(f0, scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(n):
        w[i] = x[i] + h0 * f0[i]
    closed_rhs_call(th, t + h0, w, td, tc, fw)
    calls += 1
    for i in range(n):
        dy[i] = fw[i] - f0[i]
    d2 = rms_scaled(dy, scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** 0.5
    h_abs = min(100 * h0, h1, interval)
    newton_tol = max(10 * _EPS / rtol, min(0.03, rtol ** 0.5))
    jacobian(th, t, x, f0, td, tc, J, w, fw)
    calls += n
    for i in range(n):
        D[0, i] = x[i]
        D[1, i] = f0[i] * h_abs
    order = 1
    n_equal = 0
    lu_ok = False
    while t < b:
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            change_D(D, order, min_step / h_abs, work)
            h_abs = min_step
            n_equal = 0
        current_jac = False
        accepted = False
        t_new = t
        error_norm = 0.0
        safety = 0.0
        while not accepted:
            if h_abs < min_step:
                return j, t, False, calls
            t_new = t + h_abs
            if t_new - b > 0:
                t_new = b
                change_D(D, order, abs(t_new - t) / h_abs, work)
                n_equal = 0
                lu_ok = False
            h = t_new - t
            h_abs = abs(h)
            for i in range(n):
                acc = 0.0
                for k in range(order + 1):
                    acc += D[k, i]
                ypred[i] = acc
                scale[i] = atol + rtol * abs(acc)
                acc = 0.0
                for k in range(1, order + 1):
                    acc += D[k, i] * _GAMMA[k]
                psi[i] = acc / _ALPHA[order]
            c = h / _ALPHA[order]
            converged = False
            n_iter = 0
            while not converged:
                if not lu_ok:
                    for i in range(n):
                        for q in range(n):
                            LU[i, q] = (1.0 if i == q else 0.0) - c * J[i, q]
                    lu_factor(LU, piv)
                    lu_ok = True
                # Newton iterations (scipy's solve_bdf_system)
                for i in range(n):
                    y[i] = ypred[i]
                    d[i] = 0.0
                dy_norm_old = -1.0
                converged = False
                for k in range(_NEWTON_MAXITER):
                    n_iter = k + 1
                    closed_rhs(th, t_new, y, td, tc, fw)
                    calls += 1
                    finite = True
                    for i in range(n):
                        if not math.isfinite(fw[i]):
                            finite = False
                    if not finite:
                        break
                    for i in range(n):
                        dy[i] = c * fw[i] - psi[i] - d[i]
                    lu_solve(LU, piv, dy)
                    dy_norm = rms_scaled(dy, scale)
                    rate = -1.0 if dy_norm_old < 0 else dy_norm / dy_norm_old
                    if rate >= 0 and (rate >= 1 or rate ** (_NEWTON_MAXITER - k) / (1 - rate) * dy_norm > newton_tol):
                        break
                    for i in range(n):
                        y[i] += dy[i]
                        d[i] += dy[i]
                    if dy_norm == 0 or (rate >= 0 and rate / (1 - rate) * dy_norm < newton_tol):
                        converged = True
                        break
                    dy_norm_old = dy_norm
                if not converged:
                    if current_jac:
                        break
                    closed_rhs_call(th, t_new, ypred, td, tc, f0)
                    jacobian(th, t_new, ypred, f0, td, tc, J, w, fw)
                    calls += 1 + n
                    lu_ok = False
                    current_jac = True
            if not converged:
                h_abs *= 0.5
                change_D(D, order, 0.5, work)
                n_equal = 0
                lu_ok = False
                continue
            safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
            for i in range(n):
                scale[i] = atol + rtol * abs(y[i])
                dy[i] = _ERROR_CONST[order] * d[i]
            error_norm = rms_scaled(dy, scale)
            if error_norm > 1:
                factor = max(0.2, safety * error_norm ** (-1 / (order + 1)))
                h_abs *= factor
                change_D(D, order, factor, work)
                n_equal = 0
            else:
                accepted = True
        n_equal += 1
        t_old = t
        t = t_new
        for i in range(n):
            x[i] = y[i]
            D[order + 2, i] = d[i] - D[order + 1, i]
            D[order + 1, i] = d[i]
        for k in range(order, -1, -1):
            for i in range(n):
                D[k, i] += D[k + 1, i]
        if n_equal >= order + 1:
            em = math.inf
            ep = math.inf
            if order > 1:
                for i in range(n):
                    dy[i] = _ERROR_CONST[order - 1] * D[order, i]
                em = rms_scaled(dy, scale)
            if order < _MAX_ORDER:
                for i in range(n):
                    dy[i] = _ERROR_CONST[order + 1] * D[order + 2, i]
                ep = rms_scaled(dy, scale)
            fm = math.inf if em == 0 else em ** (-1 / order)
            fc = math.inf if error_norm == 0 else error_norm ** (-1 / (order + 1))
            fp = math.inf if ep == 0 else ep ** (-1 / (order + 2))
            best, delta = fm, -1
            if fc > best:
                best, delta = fc, 0
            if fp > best:
                best, delta = fp, 1
            order += delta
            factor = min(10.0, safety * best)
            h_abs *= factor
            change_D(D, order, factor, work)
            n_equal = 0
            lu_ok = False
        # dense output on (t_old, t] (scipy's BdfDenseOutput, with the step and order now in force)
        while j < t_out.shape[0] and t_out[j] <= t + 1e-12:
            if t_out[j] >= t - 1e-15:
                for i in range(n):
                    X[i, j] = x[i]
            else:
                for i in range(n):
                    X[i, j] = D[0, i]
                p = 1.0
                for k in range(order):
                    p *= (t_out[j] - (t - h_abs * k)) / (h_abs * (1 + k))
                    for i in range(n):
                        X[i, j] += D[k + 1, i] * p
            output(th, t_out[j], X[:, j], tc, TC, ER, j)
            j += 1
        if t_old == t:
            return j, t, False, calls
    return j, t, True, calls

@jit
def rk4_step(th: Array, x: Array, a: float, b: float, td: float, tc: Array, K: Array, y: Array) -> None:
    n = x.shape[0]
    h = b - a
    torque(th, a, x, tc)
    rhs(th, a, x, tc, td, K[0])
    for i in range(n):
        y[i] = x[i] + h / 2 * K[0, i]
    rhs(th, a + h / 2, y, tc, td, K[1])
    for i in range(n):
        y[i] = x[i] + h / 2 * K[1, i]
    rhs(th, a + h / 2, y, tc, td, K[2])
    for i in range(n):
        y[i] = x[i] + h * K[2, i]
    rhs(th, b, y, tc, td, K[3])
    for i in range(n):
        x[i] = x[i] + h / 6 * (K[0, i] + 2 * K[1, i] + 2 * K[2, i] + K[3, i])

@jit
def diverged(th: Array, t: float, x: Array, limit: float) -> bool:
    for i in range(4):
        if not abs(x[i]) <= STATE_LIMIT:
            return True
    a, w = th[_REF], th[_REF + 1]
    return not (abs(a * math.sin(w * t) - x[0]) <= limit and abs(a * math.cos(w * t) - x[1]) <= limit)

@jit
def run(th: Array, x0: Array, t_out: Array, edges: Array, rtol: float, atol: float, limit: float,
        X: Array, TC: Array, ER: Array, stiff: bool) -> tuple[int, int, float, int]:
    """One run: states X (n, k), torques TC (2, k) and errors ER (4, k) on t_out; (samples, code, t_stop, calls).

    A continuous law is integrated by BDF when `stiff`, else by Dormand–Prince 5(4).
    """
    n = x0.shape[0]
    x = x0.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(2)
    calls = 0
    for i in range(n):
        X[i, 0] = x[i]
    output(th, t_out[0], x, tc, TC, ER, 0)
    j = 1  # next output sample
    h = 1e-4
    sampled = th[_TS] > 0
    for k in range(edges.shape[0] - 1):
        a, b = edges[k], edges[k + 1]
        td = th[_DIST] * disturbance_level(th, 0.5 * (a + b))
        if sampled:
            rk4_step(th, x, a, b, td, tc, K, y)
            calls += 4
            while j < t_out.shape[0] and t_out[j] <= b + 1e-12:
                for i in range(n):
                    X[i, j] = x[i]
                output(th, t_out[j], x, tc, TC, ER, j)
                j += 1
        elif stiff:
            j, t, ok, m = bdf_dense(th, x, a, b, td, rtol, atol, tc, t_out, j, X, TC, ER)
            calls += m
            if not ok:
                return j, _FAILED, t, calls
        else:
            j, t, h, ok, m = dopri_dense(th, x, a, b, td, h, rtol, atol, K, y, tc, t_out, j, X, TC, ER)
            calls += m
            if not ok:
                return j, _FAILED, t, calls
        if diverged(th, b, x, limit):
            return j, _DIVERGED, b, calls
    return j, _COMPLETED, edges[-1], calls

@jit
def refine(th: Array, x: Array, t0: float, fine: Array, counted: Array, rtol: float, atol: float) -> float:
    """max |Tc| at the `fine` times after t0 where `counted`, integrating from state x at t0 (continuous laws).

    `fine` holds the disturbance's switching instants too (not counted), so no step
    straddles a switch.
    """
    n = x.shape[0]
    z = x.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(2)
    peak = 0.0
    t = t0
    h = 1e-5
    for m in range(fine.shape[0]):
        b = fine[m]
        td = th[_DIST] * disturbance_level(th, 0.5 * (t + b))
        h, ok, _ = dopri_interval(th, z, t, b, td, h, rtol, atol, K, y, tc)
        if not ok:
            return np.nan
        t = b
        if counted[m]:
            torque(th, t, z, tc)
            peak = max(peak, abs(tc[0]), abs(tc[1]))
    return peak

@jit
def batch(TH: Array, X0: Array, t_out: Array, edges_all: Array, n_edges: Array, rtol: float, atol: float,
          limit: float, X: Array, TC: Array, ER: Array, info: Array, stiff: bool) -> None:
    for r in range(TH.shape[0]):
        j, code, t_stop, calls = run(TH[r], X0[r], t_out, edges_all[r, :n_edges[r]], rtol, atol, limit,
                                     X[r], TC[r], ER[r], stiff)
        info[r, 0], info[r, 1], info[r, 2], info[r, 3] = j, code, t_stop, calls



@jit
def segment(th: Array, x0: Array, a: float, t_eval: Array, td: float, rtol: float, atol: float, X: Array) -> bool:
    """One segment from `a` through `t_eval` with the disturbance held at `td` (N·m, before the joint signs)."""
    n = x0.shape[0]
    x = x0.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(2)
    t = a
    h = 1e-4
    for m in range(t_eval.shape[0]):
        b = t_eval[m]
        if th[_TS] > 0:
            rk4_step(th, x, t, b, td, tc, K, y)
        else:
            h, ok, _ = dopri_interval(th, x, t, b, td, h, rtol, atol, K, y, tc)
            if not ok:
                return False
        t = b
        for i in range(n):
            X[i, m] = x[i]
    return True
