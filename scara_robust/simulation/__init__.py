"""Closed-loop simulation: controllers, the closed loop, integration engines, runs and metrics.

Imports :mod:`scara_robust.model` and :mod:`scara_robust.lyapunov` (the PID's default
gain) below it.
"""

from .arm import *  # noqa: F403
from .arm import __all__ as _arm
from .compiled import *  # noqa: F403
from .compiled import __all__ as _compiled
from .controllers import *  # noqa: F403
from .controllers import __all__ as _controllers
from .engines import *  # noqa: F403
from .engines import __all__ as _engines
from .loop import *  # noqa: F403
from .loop import __all__ as _loop
from .metrics import *  # noqa: F403
from .metrics import __all__ as _metrics
from .plants import *  # noqa: F403
from .plants import __all__ as _plants
from .result import *  # noqa: F403
from .result import __all__ as _result
from .run import *  # noqa: F403
from .run import __all__ as _run

__all__ = [*_controllers, *_loop, *_engines, *_compiled, *_run, *_metrics, *_plants, *_arm, *_result]
