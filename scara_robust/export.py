"""Export a :class:`~scara_robust.DiscretePID` for a controller board: JSON, or C99 source.

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

Units: e in rad, ė in rad/s, u in N·m, Ts in s.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ._validation import check_choice, check_instance
from .exceptions import ArgumentValueError
from .io import _umask
from .lyapunov.discrete import DiscretePID

__all__ = ["EXPORT_FORMATS", "controller_record", "c_source", "export_controller", "DEFAULT_PREFIX"]

#: Formats of :func:`export_controller`: ``'c'`` writes ``<prefix>.h`` and ``<prefix>.c``,
#: ``'json'`` writes ``<prefix>.json``.
EXPORT_FORMATS = ("c", "json")
#: Default prefix of the exported names and files.
DEFAULT_PREFIX = "scara_pid"
_C_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if inline int long "
    "register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while "
    "_Bool _Complex _Imaginary".split()
)


def _check_prefix(prefix: str) -> str:
    if not isinstance(prefix, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,31}", prefix):
        raise ArgumentValueError(
            "prefix", f"must be a C identifier (a letter, then letters, digits or _, at most 32), found {prefix!r}"
        )
    if prefix in _C_KEYWORDS:
        raise ArgumentValueError("prefix", f"must not be a C keyword, found {prefix!r}")
    return prefix


def controller_record(pid: DiscretePID, **metadata: Any) -> dict[str, Any]:
    """Every gain, limit and matrix of the controller, as JSON-ready data.

    Parameters
    ----------
    pid : DiscretePID
    **metadata
        Extra keys to record (e.g. ``rho``, ``eta``, the model's name).

    Returns
    -------
    dict
        ``Ts`` (s), ``integrator``, ``derivative``, ``N`` (1/s), ``K_I``, ``K_P``, ``K_D``
        (m × p lists), ``torque_limit`` (N·m, or None), ``tracking_time`` (s),
        ``anti_windup``, and the linear part ``A, B, C, D`` with the state and input
        names, plus ``units`` and the `metadata`.
    """
    check_instance("pid", pid, DiscretePID, "a DiscretePID (Design.discretize)")
    A, B, C, D = pid.matrices()
    ss = pid.to_statespace()
    record: dict[str, Any] = {
        "kind": "scara_robust discrete PID",
        "law": "v = C z + D [e, edot]; u = clip(v, -torque_limit, torque_limit); "
        "z+ = A z + B [e, edot] + (Ts / tracking_time) (u - v) on the first n_torques states",
        "Ts": pid.Ts,
        "n_joints": pid.n_joints,
        "n_torques": pid.n_torques,
        "integrator": pid.integrator,
        "derivative": pid.derivative,
        "N": pid.N,
        "K_I": pid.K_I.tolist(),
        "K_P": pid.K_P.tolist(),
        "K_D": pid.K_D.tolist(),
        "torque_limit": None if pid.torque_limit is None else np.asarray(pid.torque_limit).tolist(),
        "tracking_time": None if pid.tracking_time is None else np.asarray(pid.tracking_time).tolist(),
        "anti_windup": bool(pid.anti_windup),
        "A": A.tolist(),
        "B": B.tolist(),
        "C": C.tolist(),
        "D": D.tolist(),
        "states": list(ss.state_labels),
        "inputs": list(ss.input_labels),
        "outputs": list(ss.output_labels),
        "units": {"e": "rad", "edot": "rad/s", "u": "N·m", "Ts": "s", "tracking_time": "s", "N": "1/s",
                  "K_I": "N·m/(rad·s)", "K_P": "N·m/rad", "K_D": "N·m·s/rad", "z": "N·m"},
    }
    record.update(metadata)
    return record


def _num(x: float) -> str:
    text = f"{float(x):.17g}"
    return text if any(c in text for c in ".eEn") else text + ".0"


def _matrix(name: str, M: np.ndarray) -> str:
    rows = ",\n    ".join("{" + ", ".join(_num(v) for v in row) + "}" for row in M)
    return f"static const double {name}[{M.shape[0]}][{M.shape[1]}] = {{\n    {rows}\n}};\n"


def c_source(pid: DiscretePID, prefix: str = DEFAULT_PREFIX, notes: Sequence[str] = ()) -> tuple[str, str]:
    """The C99 header and source of the controller.

    Parameters
    ----------
    pid : DiscretePID
    prefix : str
        C identifier that starts every exported name (and the file names).
    notes : sequence of str
        Lines for the header's opening comment (the sampled-data certificate, a warning).

    Returns
    -------
    header, source : str
        Contents of ``<prefix>.h`` and ``<prefix>.c``.
    """
    check_instance("pid", pid, DiscretePID, "a DiscretePID (Design.discretize)")
    prefix = _check_prefix(prefix)
    A, B, C, D = pid.matrices()
    p, m, nz = pid.n_joints, pid.n_torques, A.shape[0]
    up = prefix.upper()
    measured = pid.derivative == "measured"
    limited = pid.torque_limit is not None
    windup = limited and pid.anti_windup
    guard = f"{up}_H"
    settings = (
        f"Ts = {_num(pid.Ts)} s, integrator {pid.integrator}, derivative {pid.derivative}"
        + ("" if measured else f" (N = {_num(pid.N)} 1/s)")
        + (f", torque limit {[float(v) for v in np.asarray(pid.torque_limit)]} N·m" if limited else ", no torque limit")
        + (f", back-calculation T_t = {[float(v) for v in np.asarray(pid.tracking_time)]} s" if windup else "")
    )
    noted = "".join(f" * {line.replace('*/', '* /')}\n" for note in notes for line in note.splitlines())
    header = f"""/* {prefix}.h: discrete-time PID exported by scara_robust.
{noted} * {settings}.
 * e = r - q [rad], edot = rdot - qdot [rad/s], u = joint torques [N·m].
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
    double z[{nz}]; /* integral term w [N·m]{", then derivative filter state [N·m]" if not measured else ""} */
}} {prefix}_state;

void {prefix}_init({prefix}_state *s);
void {prefix}_step({prefix}_state *s, const double e[{p}], const double edot[{p}], double u[{m}]);

#endif /* {guard} */
"""
    y_fill = (
        f"    for (j = 0; j < {p}; ++j) {{\n        y[j] = e[j];\n        y[{p} + j] = edot[j];\n    }}\n"
        if measured
        else f"    for (j = 0; j < {p}; ++j) {{\n        y[j] = e[j];\n    }}\n"
    )
    unused = "" if measured else "    (void)edot; /* not read: the derivative is a filtered difference of e */\n"
    n_y = 2 * p if measured else p
    consts = _matrix("A", A) + _matrix("B", B[:, :n_y]) + _matrix("C", C) + _matrix("D", D[:, :n_y])
    if limited:
        consts += f"static const double LIMIT[{m}] = {{{', '.join(_num(v) for v in np.asarray(pid.torque_limit))}}};\n"
    if windup:
        gains = [pid.Ts / float(t) for t in np.asarray(pid.tracking_time)]
        consts += f"static const double AW[{m}] = {{{', '.join(_num(g) for g in gains)}}}; /* Ts / T_t */\n"
    clip = (
        "        x = v[i];\n        if (x < -LIMIT[i]) x = -LIMIT[i];\n        if (x > LIMIT[i]) x = LIMIT[i];\n"
        "        u[i] = x;\n"
        if limited
        else "        u[i] = v[i];\n"
    )
    aw = f"        if (i < {m}) acc += AW[i] * (u[i] - v[i]);\n" if windup else ""
    source = f"""/* {prefix}.c: discrete-time PID exported by scara_robust ({settings}). */
#include <string.h>
#include "{prefix}.h"

{consts}
void {prefix}_init({prefix}_state *s)
{{
    memset(s->z, 0, sizeof s->z);
}}

void {prefix}_step({prefix}_state *s, const double e[{p}], const double edot[{p}], double u[{m}])
{{
    double y[{n_y}], v[{m}], z[{nz}], acc{", x" if limited else ""};
    int i, j;
{y_fill}{unused}\
    for (i = 0; i < {m}; ++i) {{
        acc = 0.0;
        for (j = 0; j < {nz}; ++j) acc += C[i][j] * s->z[j];
        for (j = 0; j < {n_y}; ++j) acc += D[i][j] * y[j];
        v[i] = acc;
    }}
    for (i = 0; i < {m}; ++i) {{
{clip}    }}
    for (i = 0; i < {nz}; ++i) {{
        acc = 0.0;
        for (j = 0; j < {nz}; ++j) acc += A[i][j] * s->z[j];
        for (j = 0; j < {n_y}; ++j) acc += B[i][j] * y[j];
{aw}        z[i] = acc;
    }}
    memcpy(s->z, z, sizeof z);
}}
"""
    return header, source


def export_controller(
    pid: DiscretePID,
    folder: str | os.PathLike[str],
    *,
    format: str = "c",
    prefix: str = DEFAULT_PREFIX,
    metadata: dict[str, Any] | None = None,
    notes: Sequence[str] = (),
) -> list[Path]:
    """Write the controller into `folder`: all files or none.

    Parameters
    ----------
    pid : DiscretePID
    folder : path-like
        An existing, writable folder.
    format : {'c', 'json'}
        ``'c'``: ``<prefix>.h`` and ``<prefix>.c``; ``'json'``: ``<prefix>.json``
        (:func:`controller_record`).
    prefix : str
        C identifier; also the file names.
    metadata : dict, optional
        Extra keys for the JSON record.
    notes : sequence of str
        Lines for the C header's opening comment (see :func:`c_source`) and, in JSON,
        the record's ``notes``.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    OSError
        If the folder does not exist or is not writable; nothing is left behind.

    Examples
    --------
    >>> import tempfile, scara_robust as sr
    >>> pid = sr.design(sr.paper_model(), 3, 90).discretize(1e-3, torque_limit=50)
    >>> [p.name for p in sr.export_controller(pid, tempfile.mkdtemp())]
    ['scara_pid.h', 'scara_pid.c']
    """
    check_instance("pid", pid, DiscretePID, "a DiscretePID (Design.discretize)")
    check_choice("format", format, EXPORT_FORMATS)
    prefix = _check_prefix(prefix)
    target = Path(folder)
    if not target.is_dir():
        raise NotADirectoryError(20, "not an existing folder", str(target))
    if format == "c":
        header, source = c_source(pid, prefix, notes)
        contents = {f"{prefix}.h": header, f"{prefix}.c": source}
    else:
        record = controller_record(pid, **(metadata or {}), **({"notes": list(notes)} if notes else {}))
        contents = {f"{prefix}.json": json.dumps(record, indent=2) + "\n"}
    temps: list[str] = []
    try:
        for text in contents.values():
            fd, tmp = tempfile.mkstemp(dir=target, prefix=".tmp-")
            temps.append(tmp)
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.chmod(tmp, 0o666 & ~_umask())
        for tmp, name in zip(temps, contents):
            os.replace(tmp, target / name)
    except BaseException:
        for tmp in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise
    return [target / name for name in contents]
