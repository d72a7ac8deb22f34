"""Beyond Theorem 1: exact polytope tests, common-P LMIs, the falsifier, the certificate table.

Imports :mod:`scara_robust.model` and :mod:`scara_robust.lyapunov` below it.
"""

from .falsifier import *  # noqa: F403
from .falsifier import __all__ as _falsifier
from .l2gain import *  # noqa: F403
from .l2gain import __all__ as _l2gain
from .lmi import *  # noqa: F403
from .lmi import __all__ as _lmi
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
from .sampled import *  # noqa: F403
from .sampled import __all__ as _sampled
from .synthesis import *  # noqa: F403
from .synthesis import __all__ as _synthesis
from .table import *  # noqa: F403
from .table import __all__ as _table

__all__ = [*_polytope, *_lmi, *_falsifier, *_table, *_margins, *_synthesis, *_l2gain, *_pdl, *_sampled, *_parameters,
           *_payload]
