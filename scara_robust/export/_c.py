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
    settings = (
        f"Ts = {_num(pid.Ts)} s, integrator {pid.integrator}, derivative {pid.derivative}"
        + ("" if measured else f" (N = {_num(pid.N)} 1/s)")
        + (f", output limit {[float(v) for v in np.asarray(pid.torque_limit)]} {limit_unit}" if limited
           else ", no output limit")
        + (f", back-calculation T_t = {[float(v) for v in np.asarray(pid.tracking_time)]} s" if windup else "")
        + f", {precision} precision"
    )
    noted = "".join(f" * {line.replace('*/', '* /')}\n" for note in notes for line in note.splitlines())
    errors = ", ".join(f"{s.name} [{s.unit}]" for s in outs)
    rates = ", ".join(f"d{s.name}/dt [{per_second(s.unit)}]" for s in outs)
    driven = ", ".join(f"{s.name} [{s.unit}]" for s in ins)
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
void {prefix}_step({prefix}_state *s, const {T} e[{p}], const {T} edot[{p}], {T} u[{m}]);

#endif /* {guard} */
"""
    y_fill = (
        f"    for (j = 0; j < {p}; ++j) {{\n        y[j] = e[j];\n        y[{p} + j] = edot[j];\n    }}\n"
        if measured
        else f"    for (j = 0; j < {p}; ++j) {{\n        y[j] = e[j];\n    }}\n"
    )
    unused = "" if measured else "    (void)edot; /* not read: the derivative is a filtered difference of e */\n"
    n_y = 2 * p if measured else p
    consts = (_matrix("A", A, precision) + _matrix("B", B[:, :n_y], precision) + _matrix("C", C, precision)
              + _matrix("D", D[:, :n_y], precision))
    if limited:
        consts += f"static const {T} LIMIT[{m}] = {{{', '.join(num(v) for v in np.asarray(pid.torque_limit))}}};\n"
    if windup:
        gains = [float(g) for g in pid.back_calculation_gains]
        consts += (f"static const {T} AW[{m}] = {{{', '.join(num(g) for g in gains)}}}; "
                   "/* Ts / T_t; 0 without integral action */\n")
    band = pid.error_deadband
    if band is not None:
        consts += f"static const {T} DEADBAND = {num(band)}; /* rad: |e| within it leaves the integral term */\n"
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
    source = f"""/* {prefix}.c: discrete-time PID exported by scara_robust ({settings}). */
#include <string.h>
#include "{prefix}.h"

{consts}
void {prefix}_init({prefix}_state *s)
{{
    memset(s->z, 0, sizeof s->z);
}}

void {prefix}_step({prefix}_state *s, const {T} e[{p}], const {T} edot[{p}], {T} u[{m}])
{{
    {T} y[{n_y}], v[{m}], z[{nz}], acc{", x" if limited else ""};
    int i, j;
{y_fill}{unused}\
    for (i = 0; i < {m}; ++i) {{
        acc = {zero};
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
