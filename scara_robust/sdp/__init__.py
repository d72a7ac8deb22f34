"""LMIs described once and solved by a structure-exploiting interior-point method.

:class:`LMIProblem` describes an LMI problem (matrix and scalar variables, blocks as sums of
terms ``UᵀXV + VᵀXᵀU``, a linear objective); :func:`solve_lmi` solves it with the package's
own primal–dual interior-point method (``solver='IPM'``, the default,
:mod:`scara_robust.sdp.ipm`) or with cvxpy + Clarabel (``solver='CLARABEL'``, the
reference, extra ``lmi``) or SCS. Whichever solver answers, the analyses verify the answer
with numpy.
"""

from .backends import *  # noqa: F403
from .backends import __all__ as _backends
from .ipm import *  # noqa: F403
from .ipm import __all__ as _ipm
from .problem import *  # noqa: F403
from .problem import __all__ as _problem
from .reference import *  # noqa: F403
from .reference import __all__ as _reference

__all__ = [*_problem, *_ipm, *_reference, *_backends]
