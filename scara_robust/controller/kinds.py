"""What code outside the controller layer asks of a gain or controller, without asking its class.

The sampled controllers (:class:`DiscretePID`, :class:`SampledStateFeedback`,
:class:`SampledScheduledGain`) share one protocol: ``kind``, ``Ts``, ``linear_at(Ts)``,
``closed_loops(A, B)``, ``sampled_coordinates(P, n)``, ``step_sizes``, ``n_state_values``,
``random_inputs(rng, n_steps)`` and ``run_steps(inputs, precision)``. A gain handed to a
simulation is a matrix, a :class:`ScheduledGain` or a held :class:`SampledStateFeedback`:
:func:`schedule_of` and :func:`held_gain` say which parts it has.
"""

from __future__ import annotations

from typing import Any

from .._validation import check_instance
from .discrete import DiscretePID
from .scheduled import SampledScheduledGain, ScheduledGain
from .state_feedback import SampledStateFeedback

__all__ = ["SAMPLED_CONTROLLERS", "check_controller", "controller_kind", "held_gain", "schedule_of"]

#: The sampled controllers' classes, in the order error messages name them.
SAMPLED_CONTROLLERS = (DiscretePID, SampledStateFeedback, SampledScheduledGain)


def check_controller(name: str, value: Any, kinds: tuple[str, ...] | None = None, what: str | None = None) -> Any:
    """`value` if it is a sampled controller (of one of `kinds`), else a TypeError naming `name`.

    Parameters
    ----------
    name : str
        The argument's name.
    value : object
    kinds : tuple of str, optional
        The accepted ``kind`` values (default every sampled controller).
    what : str, optional
        What was expected, for the message.

    Returns
    -------
    DiscretePID, SampledStateFeedback or SampledScheduledGain
    """
    classes = tuple(c for c in SAMPLED_CONTROLLERS if kinds is None or c.kind in kinds)
    expected = what or " or ".join(c.__name__ for c in classes)
    return check_instance(name, value, classes, expected)


def controller_kind(value: Any) -> str | None:
    """``value.kind`` for a sampled controller, else None (a gain matrix, a Design, anything else).

    Parameters
    ----------
    value : object

    Returns
    -------
    {'pid', 'state feedback', 'scheduled'} or None
    """
    return value.kind if isinstance(value, SAMPLED_CONTROLLERS) else None


def schedule_of(gain: Any) -> ScheduledGain | None:
    """The :class:`ScheduledGain` of `gain`, or None for a fixed gain.

    Parameters
    ----------
    gain : ScheduledGain, array_like or object

    Returns
    -------
    ScheduledGain or None
    """
    return gain if isinstance(gain, ScheduledGain) else None


def held_gain(gain: Any) -> tuple[Any, float | None]:
    """``(K, Ts)`` of a held :class:`SampledStateFeedback`, else ``(gain, None)`` (a continuous law).

    Parameters
    ----------
    gain : SampledStateFeedback, array_like or object

    Returns
    -------
    K : ndarray or object
    Ts : float or None
        Sample time, s; None for a continuous law.
    """
    return (gain.K, gain.Ts) if isinstance(gain, SampledStateFeedback) else (gain, None)
