"""The paper's method: gain design from (ρ, η), Theorem 1 with Corollary 1, the surface.

Imports :mod:`scara_robust.model` and :mod:`scara_robust.controller` (the discrete PID a
design becomes) below it.
"""

from .gain import *  # noqa: F403
from .gain import __all__ as _gain
from .surface import *  # noqa: F403
from .surface import __all__ as _surface
from .theorem1 import *  # noqa: F403
from .theorem1 import __all__ as _theorem1

__all__ = [*_gain, *_theorem1, *_surface]
