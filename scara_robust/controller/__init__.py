"""The controller as it runs on a board: the discrete PID (limits, anti-windup), state feedback, a scheduled gain.

Below the paper's method (:mod:`scara_robust.lyapunov`, whose ``Design.discretize`` builds
one) and above the plant (:mod:`scara_robust.model`); the sampled-data certificate
(:mod:`scara_robust.robustness`), the simulation and the export take it.
"""

from .discrete import *  # noqa: F403
from .discrete import __all__ as _discrete
from .kinds import *  # noqa: F403
from .kinds import __all__ as _kinds
from .scheduled import *  # noqa: F403
from .scheduled import __all__ as _scheduled
from .state_feedback import *  # noqa: F403
from .state_feedback import __all__ as _state_feedback

__all__ = [*_discrete, *_state_feedback, *_scheduled, *_kinds]
