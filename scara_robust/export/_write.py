"""Writing a controller's files into a folder, all or none, in a registered format.

Private: the names of ``__all__`` are re-exported by :mod:`scara_robust.export`.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .._validation import check_choice
from ..controller.discrete import DiscretePID
from ..controller.kinds import check_controller
from ..controller.scheduled import SampledScheduledGain
from ..controller.state_feedback import SampledStateFeedback
from ..io import current_umask
from ..model.plant import Signal
from ._common import DEFAULT_PREFIX, check_prefix
from .registry import export_targets, get_target

__all__ = ["EXPORT_FORMATS", "export_controller"]

#: The built-in formats of :func:`export_controller`: ``'c'`` writes ``<prefix>.h`` and
#: ``<prefix>.c``, ``'json'`` writes ``<prefix>.json``, ``'ros2'`` ``<prefix>.yaml``; :func:`export_targets` lists them
#: and any format registered since.
EXPORT_FORMATS = ("c", "json", "ros2")


def export_controller(
    pid: DiscretePID | SampledStateFeedback | SampledScheduledGain,
    folder: str | os.PathLike[str],
    *,
    format: str = "c",
    prefix: str = DEFAULT_PREFIX,
    metadata: Mapping[str, Any] | None = None,
    notes: Sequence[str] = (),
    outputs: Sequence[Signal] | None = None,
    inputs: Sequence[Signal] | None = None,
    precision: str = "double",
) -> list[Path]:
    """Write the controller into `folder`: all files or none.

    Parameters
    ----------
    pid : DiscretePID, SampledStateFeedback or SampledScheduledGain
        The PID (stateful: ``<prefix>_init`` and ``<prefix>_step``), static state
        feedback (stateless ``<prefix>_step(x, u)``: ``u = −K x``) or a scheduled gain
        (stateless ``<prefix>_step(x, p_hat, u)``: ``u = −K(p̂) x``, returning the clamp flag).
    folder : path-like
        An existing, writable folder.
    format : str
        A registered export target (:func:`export_targets`): the built-in ``'c'``
        writes ``<prefix>.h`` and ``<prefix>.c``, ``'json'`` ``<prefix>.json``
        (:func:`controller_record`); :func:`register_target` adds others.
    prefix : str
        C identifier; also the file names.
    metadata : mapping, optional
        Extra keys for the JSON record.
    notes : sequence of str
        Lines for the C header's opening comment (see :func:`c_source`) and, in JSON,
        the record's ``notes``.
    outputs, inputs : sequence of Signal, optional
        Names and units (default: the SCARA's, see :func:`c_source`; for static feedback
        the plant's inputs u and its states x, default ``u0..``, ``x0..``).
    precision : {'double', 'single'}
        The C floating-point type (the JSON record says which the C would use).

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    OSError
        If the folder does not exist or is not writable; nothing is left behind.

    See Also
    --------
    check_sample_time : run first on the design's plant.
    single_precision_step : the float32 step in Python.

    Examples
    --------
    >>> import tempfile, scara_robust as sr
    >>> pid = sr.design(sr.paper_model(), 3, 90).discretize(1e-3, torque_limit=50)
    >>> [p.name for p in sr.export_controller(pid, tempfile.mkdtemp())]
    ['scara_pid.h', 'scara_pid.c']
    """
    check_controller("pid", pid, what="a DiscretePID (Design.discretize), a SampledStateFeedback or a "
                     "SampledScheduledGain")
    check_choice("format", format, export_targets())
    kind = get_target(format)
    prefix = check_prefix(prefix)
    target = Path(folder)
    if not target.is_dir():
        raise NotADirectoryError(20, "not an existing folder", str(target))
    contents = kind.files(pid, prefix=prefix, notes=notes, metadata=metadata, outputs=outputs, inputs=inputs,
                          precision=precision)
    temps: list[str] = []
    try:
        for text in contents.values():
            fd, tmp = tempfile.mkstemp(dir=target, prefix=".tmp-")
            temps.append(tmp)
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.chmod(tmp, 0o666 & ~current_umask())
        for tmp, name in zip(temps, contents):
            os.replace(tmp, target / name)
    except BaseException:
        for tmp in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise
    return [target / name for name in contents]
