"""Beyond Theorem 1: exact polytope tests, common-P LMIs, the falsifier, the certificate table.

Every method is registered by name in :mod:`~scara_robust.robustness.registry` (the tables and
the command line iterate it); every search for the end of an interval is
:func:`~scara_robust.robustness.search.bisect`. Imports :mod:`scara_robust.model` and
:mod:`scara_robust.lyapunov` below it.
"""

from . import certificates as _certificates  # noqa: F401  (the built-in rows register first, in the table's order)
from .actuator import *  # noqa: F403
from .actuator import __all__ as _actuator
from .context import *  # noqa: F403
from .context import __all__ as _context
from .decay import *  # noqa: F403
from .decay import __all__ as _decay
from .falsifier import *  # noqa: F403
from .falsifier import __all__ as _falsifier
from .jitter import *  # noqa: F403
from .jitter import __all__ as _jitter
from .l2gain import *  # noqa: F403
from .l2gain import __all__ as _l2gain
from .l2rate import *  # noqa: F403
from .l2rate import __all__ as _l2rate
from .lmi import *  # noqa: F403
from .lmi import __all__ as _lmi
from .loop_margins import *  # noqa: F403
from .loop_margins import __all__ as _loop_margins
from .margins import *  # noqa: F403
from .margins import __all__ as _margins
from .parameters import *  # noqa: F403
from .parameters import __all__ as _parameters
from .payload import *  # noqa: F403
from .payload import __all__ as _payload
from .pdl import *  # noqa: F403
from .pdl import __all__ as _pdl
from .polytope import *  # noqa: F403
from .polytope import __all__ as _polytope
from .registry import *  # noqa: F403
from .registry import __all__ as _registry
from .sampled import *  # noqa: F403
from .sampled import __all__ as _sampled
from .sampled_synthesis import *  # noqa: F403
from .sampled_synthesis import __all__ as _sampled_synthesis
from .scheduled import *  # noqa: F403
from .scheduled import __all__ as _scheduled
from .search import *  # noqa: F403
from .search import __all__ as _search
from .synthesis import *  # noqa: F403
from .synthesis import __all__ as _synthesis
from .table import *  # noqa: F403
from .table import __all__ as _table
from .tracking import *  # noqa: F403
from .tracking import __all__ as _tracking
from .tuning import *  # noqa: F403
from .tuning import __all__ as _tuning

__all__ = [*_polytope, *_lmi, *_falsifier, *_table, *_margins, *_synthesis, *_l2gain, *_pdl, *_sampled,
           *_sampled_synthesis, *_jitter, *_parameters, *_payload, *_registry, *_context, *_search, *_l2rate, *_decay,
           *_actuator, *_loop_margins, *_scheduled, *_tracking, *_tuning]
