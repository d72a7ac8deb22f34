"""The paper's method: gain design from (ρ, η), its discrete-time PID, Theorem 1 with Corollary 1, the surface.

Imports only :mod:`scara_robust.model` below it.
"""

from .discrete import *  # noqa: F403
from .discrete import __all__ as _discrete
from .gain import *  # noqa: F403
from .gain import __all__ as _gain
from .surface import *  # noqa: F403
from .surface import __all__ as _surface
from .theorem1 import *  # noqa: F403
from .theorem1 import __all__ as _theorem1

__all__ = [*_gain, *_discrete, *_theorem1, *_surface]
