"""The C target (``'c'``): one header and one source file, C99, per controller.

Private: the names of ``__all__`` are re-exported by :mod:`scara_robust.export`.

The C export is one header and one source file, self-contained (``<string.h>`` only, no
dynamic allocation, no global state besides constants)::

    typedef struct { double z[NZ]; } <prefix>_state;
    void <prefix>_init(<prefix>_state *s);
    void <prefix>_step(<prefix>_state *s, const double e[P], const double edot[P], double u[M]);

``<prefix>_init`` is :meth:`DiscretePID.reset` without arguments (state zero: integral
term 0, the paper's ``∫e(0) = 0``) and ``<prefix>_step`` is :meth:`DiscretePID.step`:
the same constants (written with 17 significant digits, so they read back as the same
doubles) and the same operations in the same order, so both agree to rounding as long as
the compiler does not contract or reorder floating-point operations (no ``-ffast-math``;
``-ffp-contract=off`` where FMA instructions are enabled). With ``derivative='filtered'``
``edot`` is not read and may be NULL.

With ``precision='single'`` every ``double`` is a ``float`` (for boards whose FPU is
single precision only), the constants are written with 9 significant digits (they read back
as the same floats), and :func:`single_precision_step` is the Python step it matches to
rounding: the same float32 operations in the same order.

Units and names come from the plant (:class:`~scara_robust.Signal`): by default the SCARA's,
e in rad, ė in rad/s, u in N·m; Ts in s.

Static state feedback (:class:`~scara_robust.SampledStateFeedback`) is exported the same way,
stateless: ``void <prefix>_step(const double x[NX], double u[NU])`` computes ``u = −K x``
(called every Ts, its output held until the next call).

A scheduled gain (:class:`~scara_robust.SampledScheduledGain`) is stateless too, with the
measured parameter as an input and the breakpoint table as constants:
``int <prefix>_step(const double x[NX], double p_hat, double u[NU])`` computes
``u = −K(p̂) x``, K linear between the breakpoints; a p̂ outside them (or not a number)
takes the edge gain and the step returns 1, the flag the caller reads (the certificate
does not cover it), else 0. The header records what the schedule was certified for.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .._validation import check_choice
from ..controller.discrete import DiscretePID
from ..controller.kinds import check_controller
from ..controller.scheduled import SampledScheduledGain
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentValueError
from ..model.plant import Signal
from ._common import DEFAULT_PREFIX, PRECISIONS, check_prefix, per_second, signal_names, unit_of
from .registry import ExportTarget, register_target

__all__ = ["c_source"]


def _num(x: float, precision: str = "double") -> str:
    if precision == "single":
        text = f"{float(np.float32(x)):.9g}"
        return (text if any(c in text for c in ".eEn") else text + ".0") + "f"
    text = f"{float(x):.17g}"
    return text if any(c in text for c in ".eEn") else text + ".0"


def _matrix(name: str, M: np.ndarray, precision: str = "double") -> str:
    ctype = "float" if precision == "single" else "double"
    rows = ",\n    ".join("{" + ", ".join(_num(v, precision) for v in row) + "}" for row in M)
    return f"static const {ctype} {name}[{M.shape[0]}][{M.shape[1]}] = {{\n    {rows}\n}};\n"


def c_source(
    pid: DiscretePID,
    prefix: str = DEFAULT_PREFIX,
    notes: Sequence[str] = (),
    *,
    outputs: Sequence[Signal] | None = None,
    inputs: Sequence[Signal] | None = None,
    precision: str = "double",
) -> tuple[str, str]:
    """The C99 header and source of the controller.

    Parameters
    ----------
    pid : DiscretePID
    prefix : str
        C identifier that starts every exported name (and the file names).
    notes : sequence of str
        Lines for the header's opening comment (the sampled-data certificate, a warning).
    outputs, inputs : sequence of Signal, optional
        Names and units of the controlled outputs (the errors' signals) and of the
        inputs driven, for the comments (default: the SCARA's, rad and N·m).
    precision : {'double', 'single'}
        The C floating-point type.

    Returns
    -------
    header, source : str
        Contents of ``<prefix>.h`` and ``<prefix>.c``.
    """
    check_controller("pid", pid, ("pid",), "a DiscretePID (Design.discretize)")
    prefix = check_prefix(prefix)
    check_choice("precision", precision, PRECISIONS)
    outs, ins = signal_names(pid, outputs, inputs)
    T = "float" if precision == "single" else "double"

    def num(x: float) -> str:
        return _num(x, precision)

    A, B, C, D = pid.matrices()
    p, m, nz = pid.n_joints, pid.n_torques, A.shape[0]
    up = prefix.upper()
    measured = pid.derivative == "measured"
    limited = pid.torque_limit is not None
    windup = pid.back_calculation
    guard = f"{up}_H"
    u_units = unit_of([s.unit for s in ins])
    limit_unit = u_units if isinstance(u_units, str) else "/".join(u_units)
    settings = _settings(pid, limit_unit, precision)
    noted = "".join(f" * {line.replace('*/', '* /')}\n" for note in notes for line in note.splitlines())
    errors = ", ".join(f"{s.name} [{s.unit}]" for s in outs)
    rates = ", ".join(f"d{s.name}/dt [{per_second(s.unit)}]" for s in outs)
    driven = ", ".join(f"{s.name} [{s.unit}]" for s in ins)
    ff = pid.feedforward
    if ff is not None and precision != "double":
        raise ArgumentValueError("precision", "of a PID with a model feedforward is 'double' (its RNEA is checked "
                                              "against Pinocchio in double precision)")
    step_decl = (f"void {prefix}_step({prefix}_state *s, const {T} e[{p}], const {T} edot[{p}], {T} u[{m}]);\n"
                 if ff is None else _feedforward_declarations(prefix, p, ff))
    header = f"""/* {prefix}.h: discrete-time PID exported by scara_robust.
{noted} * {settings}.
 * e[j] = reference - measured for {errors}; edot[j] = the same for {rates}.
 * u = {driven}.
 * Call {prefix}_init once, then {prefix}_step once per sample; hold u until the next sample.
 * Compile without -ffast-math (and with -ffp-contract=off where FMA is enabled) to match
 * the Python controller to rounding. No dynamic allocation.
 */
#ifndef {guard}
#define {guard}

#define {up}_N_JOINTS {p}
#define {up}_N_TORQUES {m}
#define {up}_N_STATES {nz}
#define {up}_TS {_num(pid.Ts)}

typedef struct {{
    {T} z[{nz}]; /* integral term w [{limit_unit}]{", then derivative filter state" if not measured else ""} */
}} {prefix}_state;

void {prefix}_init({prefix}_state *s);
{step_decl}
#endif /* {guard} */
"""
    y_fill = (
        f"    for (j = 0; j < {p}; ++j) {{\n        y[j] = e[j];\n        y[{p} + j] = edot[j];\n    }}\n"
        if measured
        else f"    for (j = 0; j < {p}; ++j) {{\n        y[j] = e[j];\n    }}\n"
    )
    unused = "" if measured else "    (void)edot; /* not read: the derivative is a filtered difference of e */\n"
    n_y = 2 * p if measured else p
    consts = _constants(pid, n_y, precision)
    band = pid.error_deadband
    clip = (
        "        x = v[i];\n        if (x < -LIMIT[i]) x = -LIMIT[i];\n        if (x > LIMIT[i]) x = LIMIT[i];\n"
        "        u[i] = x;\n"
        if limited
        else "        u[i] = v[i];\n"
    )
    aw = f"        if (i < {m}) acc += AW[i] * (u[i] - v[i]);\n" if windup else ""
    zero = num(0.0)
    deadband = ("" if band is None else
                f"        if (i < {m} && y[i] >= -DEADBAND && y[i] <= DEADBAND) {{ z[i] = s->z[i]; continue; }}\n")
    if ff is None:
        signature = f"void {prefix}_step({prefix}_state *s, const {T} e[{p}], const {T} edot[{p}], {T} u[{m}])"
        start, ff_text, first = "", "", zero
    else:
        signature = (f"void {prefix}_step({prefix}_state *s, const {T} r[{p}], const {T} rd[{p}], const {T} rdd[{p}], "
                     f"const {T} q[{p}], const {T} qd[{p}], {T} u[{m}])")
        start = (f"    {T} e[{p}], edot[{p}], ff[{m}];\n    for (j = 0; j < {p}; ++j) {{\n        e[j] = r[j] - q[j];\n"
                 f"        edot[j] = rd[j] - qd[j];\n    }}\n    {prefix}_feedforward(r, rd, rdd, ff);\n")
        ff_text, first = _feedforward_source(prefix, ff, num), "ff[i]"
    source = f"""/* {prefix}.c: discrete-time PID exported by scara_robust ({settings}). */
#include <string.h>
{"#include <math.h>" + chr(10) if ff is not None else ""}#include "{prefix}.h"

{consts}{ff_text}
void {prefix}_init({prefix}_state *s)
{{
    memset(s->z, 0, sizeof s->z);
}}

{signature}
{{
    {T} y[{n_y}], v[{m}], z[{nz}], acc{", x" if limited else ""};
    int i, j;
{start}{y_fill}{unused}\
    for (i = 0; i < {m}; ++i) {{
        acc = {first};
        for (j = 0; j < {nz}; ++j) acc += C[i][j] * s->z[j];
        for (j = 0; j < {n_y}; ++j) acc += D[i][j] * y[j];
        v[i] = acc;
    }}
    for (i = 0; i < {m}; ++i) {{
{clip}    }}
    for (i = 0; i < {nz}; ++i) {{
{deadband}        acc = {zero};
        for (j = 0; j < {nz}; ++j) acc += A[i][j] * s->z[j];
        for (j = 0; j < {n_y}; ++j) acc += B[i][j] * y[j];
{aw}        z[i] = acc;
    }}
    memcpy(s->z, z, sizeof z);
}}
"""
    return header, source


def _constants(pid: DiscretePID, n_y: int, precision: str) -> str:
    """The PID's constant arrays: A, B, C, D, and the limit, anti-windup gains and deadband it has."""
    T = "float" if precision == "single" else "double"
    m = pid.n_torques
    A, B, C, D = pid.matrices()

    def num(x: float) -> str:
        return _num(x, precision)

    consts = (_matrix("A", A, precision) + _matrix("B", B[:, :n_y], precision) + _matrix("C", C, precision)
              + _matrix("D", D[:, :n_y], precision))
    if pid.torque_limit is not None:
        consts += f"static const {T} LIMIT[{m}] = {{{', '.join(num(v) for v in np.asarray(pid.torque_limit))}}};\n"
    if pid.back_calculation:
        gains = [float(g) for g in pid.back_calculation_gains]
        consts += (f"static const {T} AW[{m}] = {{{', '.join(num(g) for g in gains)}}}; "
                   "/* Ts / T_t; 0 without integral action */\n")
    if pid.error_deadband is not None:
        consts += (f"static const {T} DEADBAND = {num(pid.error_deadband)}; "
                   "/* rad: |e| within it leaves the integral term */\n")
    return consts


def _settings(pid: DiscretePID, limit_unit: str, precision: str) -> str:
    """The PID's settings in one line, for the files' opening comments."""
    return (f"Ts = {_num(pid.Ts)} s, integrator {pid.integrator}, derivative {pid.derivative}"
            + ("" if pid.derivative == "measured" else f" (N = {_num(pid.N)} 1/s)")
            + (f", output limit {[float(v) for v in np.asarray(pid.torque_limit)]} {limit_unit}"
               if pid.torque_limit is not None else ", no output limit")
            + (f", back-calculation T_t = {[float(v) for v in np.asarray(pid.tracking_time)]} s"
               if pid.back_calculation else "")
            + f", {precision} precision")


def _feedforward_declarations(prefix: str, p: int, ff: Any) -> str:
    """The header's functions of a PID with an arm's model feedforward."""
    what = "G(r)" if ff.kind == "gravity" else "M(r) rdd + C(r, rd) rd + G(r)"
    return (f"/* The {ff.kind} feedforward tau_ff = {what} [N·m] at the nominal payload {ff.payload:g} kg, by RNEA on\n"
            f" * the arm's rigid bodies (checked against Pinocchio at export); r, rd, rdd in rad, rad/s, rad/s². */\n"
            f"void {prefix}_feedforward(const double r[{p}], const double rd[{p}], const double rdd[{p}], "
            f"double tau[{p}]);\n"
            f"/* The whole controller, once per sample: u = clip(tau_ff(r, rd, rdd) + PID(r - q, rd - qd)), the limit\n"
            f" * on the total torque; q, qd measured (rad, rad/s). */\n"
            f"void {prefix}_step({prefix}_state *s, const double r[{p}], const double rd[{p}], const double rdd[{p}], "
            f"const double q[{p}], const double qd[{p}], double u[{p}]);\n")


def _feedforward_source(prefix: str, ff: Any, num: Callable[[float], str]) -> str:
    """The feedforward's tables and its RNEA pass: :meth:`ArmFeedforward.torque`'s operations in its order."""
    n = ff.n_joints
    parents = ", ".join(str(v) for v in ff.parents)
    joint_body = ", ".join(str(v) for v in ff.joint_body)
    gravity = ", ".join(num(float(v)) for v in ff.gravity)
    ct = ff.kind == "computed-torque"
    fill = ("        qd[b] = rd[k];\n        qdd[b] = rdd[k];\n" if ct else "")
    unused = "" if ct else "    (void)rd;\n    (void)rdd;\n"
    return (_matrix("FF_TREE", ff.tree) + _matrix("FF_BODY", ff.body)
            + f"static const int FF_PARENT[{n}] = {{{parents}}};\n"
            + f"static const int FF_JOINT_BODY[{n}] = {{{joint_body}}};\n"
            + f"static const double FF_GRAVITY[3] = {{{gravity}}};\n"
            + _RNEA.replace("PREFIX", prefix).replace("NB", str(n)).replace("FILL\n", fill)
            .replace("UNUSED\n", unused))


# One RNEA pass, the operations of ArmFeedforward.torque in its order (spatial vectors linear part first).
_RNEA = """
static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static void back3(const double R[9], const double v[3], double out[3])
{
    out[0] = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
    out[1] = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
    out[2] = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];
}

static void forward3(const double R[9], const double v[3], double out[3])
{
    out[0] = R[0] * v[0] + R[1] * v[1] + R[2] * v[2];
    out[1] = R[3] * v[0] + R[4] * v[1] + R[5] * v[2];
    out[2] = R[6] * v[0] + R[7] * v[1] + R[8] * v[2];
}

static void momentum(const double b[13], const double v[3], const double w[3], double lin[3], double ang[3])
{
    double h[3], hw[3], hv[3];
    h[0] = b[1];
    h[1] = b[2];
    h[2] = b[3];
    cross3(h, w, hw);
    cross3(h, v, hv);
    lin[0] = b[0] * v[0] - hw[0];
    lin[1] = b[0] * v[1] - hw[1];
    lin[2] = b[0] * v[2] - hw[2];
    ang[0] = b[4] * w[0] + b[5] * w[1] + b[6] * w[2] + hv[0];
    ang[1] = b[7] * w[0] + b[8] * w[1] + b[9] * w[2] + hv[1];
    ang[2] = b[10] * w[0] + b[11] * w[1] + b[12] * w[2] + hv[2];
}

void PREFIX_feedforward(const double r[NB], const double rd[NB], const double rdd[NB], double tau[NB])
{
    double q[NB], qd[NB], qdd[NB], R[NB][9], V[NB][3], W[NB][3], AL[NB][3], AW[NB][3], F[NB][6], taub[NB];
    double zero[3] = {0.0, 0.0, 0.0}, grav[3], t[3], u[3], p[3], sq[3], pw[3], w0[3], pa[3], al0[3], aw0[3];
    double vs[3], ws[3], il[3], ia[3], fl[3], fa[3], c1[3], c2[3], c3[3], pf[3];
    const double *vp, *wp, *alp, *awp;
    double c, s, k1, ax, ay, az, j[9], p0, p1, p2;
    int i, k, b, row, par;
UNUSED
    for (i = 0; i < NB; ++i) {
        q[i] = 0.0;
        qd[i] = 0.0;
        qdd[i] = 0.0;
    }
    for (k = 0; k < NB; ++k) {
        b = FF_JOINT_BODY[k];
        q[b] = r[k];
FILL
    }
    grav[0] = -FF_GRAVITY[0];
    grav[1] = -FF_GRAVITY[1];
    grav[2] = -FF_GRAVITY[2];
    for (i = 0; i < NB; ++i) {
        const double *T = FF_TREE[i];
        c = cos(q[i]);
        s = sin(q[i]);
        ax = T[12];
        ay = T[13];
        az = T[14];
        k1 = 1.0 - c;
        j[0] = c + k1 * ax * ax;
        j[1] = k1 * ax * ay - s * az;
        j[2] = k1 * ax * az + s * ay;
        j[3] = k1 * ay * ax + s * az;
        j[4] = c + k1 * ay * ay;
        j[5] = k1 * ay * az - s * ax;
        j[6] = k1 * az * ax - s * ay;
        j[7] = k1 * az * ay + s * ax;
        j[8] = c + k1 * az * az;
        for (row = 0; row < 3; ++row) {
            p0 = T[3 * row];
            p1 = T[3 * row + 1];
            p2 = T[3 * row + 2];
            R[i][3 * row] = p0 * j[0] + p1 * j[3] + p2 * j[6];
            R[i][3 * row + 1] = p0 * j[1] + p1 * j[4] + p2 * j[7];
            R[i][3 * row + 2] = p0 * j[2] + p1 * j[5] + p2 * j[8];
        }
        par = FF_PARENT[i];
        if (par < 0) {
            vp = zero;
            wp = zero;
            alp = grav;
            awp = zero;
        } else {
            vp = V[par];
            wp = W[par];
            alp = AL[par];
            awp = AW[par];
        }
        p[0] = T[9];
        p[1] = T[10];
        p[2] = T[11];
        sq[0] = ax * qd[i];
        sq[1] = ay * qd[i];
        sq[2] = az * qd[i];
        cross3(p, wp, pw);
        t[0] = vp[0] - pw[0];
        t[1] = vp[1] - pw[1];
        t[2] = vp[2] - pw[2];
        back3(R[i], t, V[i]);
        back3(R[i], wp, w0);
        W[i][0] = w0[0] + sq[0];
        W[i][1] = w0[1] + sq[1];
        W[i][2] = w0[2] + sq[2];
        cross3(p, awp, pa);
        t[0] = alp[0] - pa[0];
        t[1] = alp[1] - pa[1];
        t[2] = alp[2] - pa[2];
        back3(R[i], t, al0);
        back3(R[i], awp, aw0);
        cross3(V[i], sq, vs);
        cross3(W[i], sq, ws);
        AL[i][0] = al0[0] + vs[0];
        AL[i][1] = al0[1] + vs[1];
        AL[i][2] = al0[2] + vs[2];
        AW[i][0] = aw0[0] + ax * qdd[i] + ws[0];
        AW[i][1] = aw0[1] + ay * qdd[i] + ws[1];
        AW[i][2] = aw0[2] + az * qdd[i] + ws[2];
        momentum(FF_BODY[i], V[i], W[i], il, ia);
        momentum(FF_BODY[i], AL[i], AW[i], fl, fa);
        cross3(W[i], il, c1);
        cross3(W[i], ia, c2);
        cross3(V[i], il, c3);
        for (k = 0; k < 3; ++k) {
            F[i][k] = fl[k] + c1[k];
            F[i][3 + k] = fa[k] + c2[k] + c3[k];
        }
    }
    for (i = NB - 1; i >= 0; --i) {
        const double *T = FF_TREE[i];
        taub[i] = T[12] * F[i][3] + T[13] * F[i][4] + T[14] * F[i][5] + T[15] * qdd[i];
        par = FF_PARENT[i];
        if (par >= 0) {
            forward3(R[i], F[i], fl);
            forward3(R[i], F[i] + 3, fa);
            p[0] = T[9];
            p[1] = T[10];
            p[2] = T[11];
            cross3(p, fl, pf);
            for (k = 0; k < 3; ++k) {
                F[par][k] += fl[k];
                F[par][3 + k] += fa[k] + pf[k];
            }
        }
    }
    for (k = 0; k < NB; ++k) {
        tau[k] = taub[FF_JOINT_BODY[k]];
    }
    (void)u;
}
"""


def _feedback_signals(n: int, m: int, inputs: Sequence[Signal] | None,
                      outputs: Sequence[Signal] | None) -> tuple[list[Signal], list[Signal]]:
    """The n states read and m inputs written by a state feedback (default ``x0..``, ``u0..``), their counts checked."""
    xs = list(inputs) if inputs is not None else [Signal(f"x{i}", "model units") for i in range(n)]
    us = list(outputs) if outputs is not None else [Signal(f"u{j}", "model units") for j in range(m)]
    if len(xs) != n:
        raise ArgumentValueError("inputs", f"must name the {n} states fed back, found {len(xs)}")
    if len(us) != m:
        raise ArgumentValueError("outputs", f"must name the {m} plant inputs, found {len(us)}")
    return xs, us


def _gain_files(ctrl: SampledStateFeedback, prefix: str, notes: Sequence[str], inputs: Sequence[Signal] | None,
                outputs: Sequence[Signal] | None, precision: str) -> dict[str, str]:
    """``<prefix>.h`` and ``<prefix>.c`` of static state feedback ``u = −K x``."""
    check_choice("precision", precision, PRECISIONS)
    m, n = ctrl.K.shape
    xs, us = _feedback_signals(n, m, inputs, outputs)
    ctype = "float" if precision == "single" else "double"
    macro = prefix.upper()
    signals = "\n".join([f" *   x[{i}] = {sig.name} [{sig.unit}]" for i, sig in enumerate(xs)]
                        + [f" *   u[{j}] = {sig.name} [{sig.unit}]" for j, sig in enumerate(us)])
    comment = "".join(f" * {line}\n" for line in notes)
    header = f"""/* {prefix}: static state feedback u = -K x, sampled every Ts = {ctrl.Ts:.17g} s and held
 * until the next sample (zero-order hold). Call {prefix}_step once per sample.
{comment}{signals}
 */
#ifndef {macro}_H
#define {macro}_H

#define {macro}_NX {n}
#define {macro}_NU {m}
#define {macro}_TS {_num(ctrl.Ts, precision)}

void {prefix}_step(const {ctype} x[{macro}_NX], {ctype} u[{macro}_NU]);

#endif
"""
    source = f"""#include "{prefix}.h"

{_matrix("K", ctrl.K, precision)}
void {prefix}_step(const {ctype} x[{macro}_NX], {ctype} u[{macro}_NU])
{{
    int i, j;
    for (j = 0; j < {macro}_NU; ++j) {{
        {ctype} sum = {_num(0.0, precision)};
        for (i = 0; i < {macro}_NX; ++i) {{
            sum += K[j][i] * x[i];
        }}
        u[j] = -sum;
    }}
}}
"""
    return {f"{prefix}.h": header, f"{prefix}.c": source}


def _scheduled_files(ctrl: SampledScheduledGain, prefix: str, notes: Sequence[str],
                     inputs: Sequence[Signal] | None, outputs: Sequence[Signal] | None,
                     precision: str) -> dict[str, str]:
    """``<prefix>.h`` and ``<prefix>.c`` of a scheduled gain ``u = −K(p̂) x`` (see the module docstring)."""
    check_choice("precision", precision, PRECISIONS)
    g = ctrl.gain
    m, n = g.shape
    nb = g.breakpoints.size
    xs, us = _feedback_signals(n, m, inputs, outputs)
    ctype = "float" if precision == "single" else "double"
    macro = prefix.upper()
    lo, hi = g.range
    certified = [f"{key} = {value}" for key, value in g.certified.items()]
    if not certified:
        certified = ["nothing: this schedule carries no certificate"]
    signals = "\n".join([f" *   x[{i}] = {sig.name} [{sig.unit}]" for i, sig in enumerate(xs)]
                        + [f" *   p_hat = measured {g.parameter} [{g.unit}]"]
                        + [f" *   u[{j}] = {sig.name} [{sig.unit}]" for j, sig in enumerate(us)])
    comment = "".join(f" * {line}\n" for line in notes)
    record = "".join(f" *   {line}\n" for line in certified)
    header = f"""/* {prefix}: a gain scheduled on the measured {g.parameter} [{g.unit}], u = -K(p_hat) x, sampled every
 * Ts = {ctrl.Ts:.17g} s and held until the next sample. K is linear between the {nb} breakpoints
 * {lo:.17g} ... {hi:.17g} {g.unit}; outside them the edge gain is used and {prefix}_step returns 1.
 * Certified for:
{record}{comment}{signals}
 */
#ifndef {macro}_H
#define {macro}_H

#define {macro}_NX {n}
#define {macro}_NU {m}
#define {macro}_NB {nb}
#define {macro}_TS {_num(ctrl.Ts, precision)}
#define {macro}_P_MIN {_num(lo, precision)}
#define {macro}_P_MAX {_num(hi, precision)}

/* Returns 1 when p_hat lay outside [{macro}_P_MIN, {macro}_P_MAX] or was not a number (the edge gain
 * was used: outside what was certified), else 0. */
int {prefix}_step(const {ctype} x[{macro}_NX], {ctype} p_hat, {ctype} u[{macro}_NU]);

#endif
"""
    table = ", ".join(_num(v, precision) for v in g.breakpoints)
    gains = ",\n    ".join(
        "{" + ", ".join("{" + ", ".join(_num(v, precision) for v in row) + "}" for row in K) + "}" for K in g.gains)
    one, zero = _num(1.0, precision), _num(0.0, precision)
    source = f"""#include "{prefix}.h"

static const {ctype} BREAKPOINTS[{macro}_NB] = {{{table}}};
static const {ctype} GAINS[{macro}_NB][{macro}_NU][{macro}_NX] = {{
    {gains}
}};

int {prefix}_step(const {ctype} x[{macro}_NX], {ctype} p_hat, {ctype} u[{macro}_NU])
{{
    int i, k, j = 0, clamped = 0;
    {ctype} p = p_hat, s;
    if (!(p >= BREAKPOINTS[0])) {{
        p = BREAKPOINTS[0];
        clamped = 1;
    }} else if (p > BREAKPOINTS[{macro}_NB - 1]) {{
        p = BREAKPOINTS[{macro}_NB - 1];
        clamped = 1;
    }}
    while (j < {macro}_NB - 2 && p >= BREAKPOINTS[j + 1]) {{
        ++j;
    }}
    s = (p - BREAKPOINTS[j]) / (BREAKPOINTS[j + 1] - BREAKPOINTS[j]);
    for (i = 0; i < {macro}_NU; ++i) {{
        {ctype} acc = {zero};
        for (k = 0; k < {macro}_NX; ++k) {{
            {ctype} gain = ({one} - s) * GAINS[j][i][k] + s * GAINS[j + 1][i][k];
            acc = acc + gain * x[k];
        }}
        u[i] = -acc;
    }}
    return clamped;
}}
"""
    return {f"{prefix}.h": header, f"{prefix}.c": source}


def _c_files(
    controller: DiscretePID | SampledStateFeedback | SampledScheduledGain,
    *,
    prefix: str,
    notes: Sequence[str],
    metadata: Mapping[str, Any] | None,
    outputs: Sequence[Signal] | None,
    inputs: Sequence[Signal] | None,
    precision: str,
) -> dict[str, str]:
    """``write`` of the C target: ``{'.h': header, '.c': source}`` (`metadata` is not written)."""
    given: Any = controller  # its kind says which writer takes it
    writers: dict[str, Callable[..., dict[str, str]]] = {"scheduled": _scheduled_files, "state feedback": _gain_files}
    fixed = writers.get(given.kind)
    if fixed is not None:
        files = fixed(given, prefix, notes, inputs, outputs, precision)
        return {name.removeprefix(prefix): text for name, text in files.items()}
    header, source = c_source(given, prefix, notes, outputs=outputs, inputs=inputs, precision=precision)
    return {".h": header, ".c": source}


register_target(ExportTarget(
    "c", ".c", "C99 source: <prefix>.h and <prefix>.c (<prefix>_init, <prefix>_step), in double or single precision",
    _c_files,
))
