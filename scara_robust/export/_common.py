"""What every export target shares: the prefix of the names and files, the precisions, the signals.

Private: the names of ``__all__`` are re-exported by :mod:`scara_robust.export`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from .._validation import check_instance
from ..controller.discrete import DiscretePID
from ..exceptions import ArgumentValueError
from ..model.plant import Signal

__all__ = ["PRECISIONS", "DEFAULT_PREFIX"]

#: Floating-point types of the C export.
PRECISIONS = ("double", "single")

#: Default prefix of the exported names and files.
DEFAULT_PREFIX = "scara_pid"
_C_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if inline int long "
    "register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while "
    "_Bool _Complex _Imaginary".split()
)


def check_prefix(prefix: str) -> str:
    if not isinstance(prefix, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,31}", prefix):
        raise ArgumentValueError(
            "prefix", f"must be a C identifier (a letter, then letters, digits or _, at most 32), found {prefix!r}"
        )
    if prefix in _C_KEYWORDS:
        raise ArgumentValueError("prefix", f"must not be a C keyword, found {prefix!r}")
    return prefix


def signal_names(pid: DiscretePID, outputs: Sequence[Signal] | None,
             inputs: Sequence[Signal] | None) -> tuple[tuple[Signal, ...], tuple[Signal, ...]]:
    outs = tuple(outputs) if outputs else tuple(Signal(f"q{i + 1}", "rad") for i in range(pid.n_joints))
    ins = tuple(inputs) if inputs else tuple(Signal(f"T{i + 1}", "N·m") for i in range(pid.n_torques))
    if len(outs) != pid.n_joints:
        raise ArgumentValueError("outputs", f"must name the PID's {pid.n_joints} errors, found {len(outs)}")
    if len(ins) != pid.n_torques:
        raise ArgumentValueError("inputs", f"must name the PID's {pid.n_torques} outputs, found {len(ins)}")
    for k, sig in enumerate((*outs, *ins)):
        check_instance(f"signals[{k}]", sig, Signal, "a Signal(name, unit)")
    return outs, ins


def unit_of(units: Sequence[str]) -> str | list[str]:
    return units[0] if len(set(units)) == 1 else list(units)


def per_second(unit: str) -> str:
    """The unit of a rate of change: ``rad`` → ``rad/s``, ``1/s`` → ``1/s²``, ``m/s²`` → ``(m/s²)/s``."""
    if unit in ("1", ""):
        return "1/s"
    if unit.endswith("/s") and "(" not in unit:
        return f"{unit}²"
    return f"({unit})/s" if "/" in unit else f"{unit}/s"
