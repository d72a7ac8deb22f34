"""The design of a system at (ρ, η) and the file that records it, as every front end gives it."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..io import design_record
from ..lyapunov.gain import Design, design
from ..lyapunov.theorem1 import certify
from ..robustness.polytope import vertex_certificate
from .system import LoadedSystem

__all__ = ["DesignAnswer", "design_answer"]


@dataclass(frozen=True)
class DesignAnswer:
    """K(ρ, η) of a system, its certificate, and the record its design file holds.

    Attributes
    ----------
    design : Design
    certificate : Theorem1Certificate or VertexCertificate
        Theorem 1 over the chosen elements for an interval box; the exact test at the
        vertices for a polytope (which Theorem 1 does not take).
    record : dict
        Every number of the design (ρ, η, the model, K and its PID gains, the closed-loop
        poles, the Riccati residual) and of the certificate, JSON-ready.
    """

    design: Design
    certificate: Any
    record: dict[str, Any]

    def file_text(self) -> str:
        """The design file (JSON, :func:`scara_robust.load_design` reads it) that also holds the certificate.

        Returns
        -------
        str
        """
        d = self.design
        return json.dumps(design_record(d.K, d.P, method="design", **{k: v for k, v in self.record.items()
                                                                       if k != "K"}), indent=2)


def design_answer(system: LoadedSystem, rho: float, eta: float, elements: str = "all") -> DesignAnswer:
    """Design K(ρ, η) on `system`'s uncertainty set and certify it.

    Parameters
    ----------
    system : LoadedSystem
    rho, eta : float
        The design point.
    elements : {'all', 'A', 'B'}
        The elements Theorem 1 covers (an interval box only).

    Returns
    -------
    DesignAnswer
    """
    model = system.model
    d = design(model, rho, eta)
    record: dict[str, Any] = {
        "rho": d.rho,
        "eta": d.eta,
        "model": model.name,
        "bounds": system.bounds,
        "elements": elements,
        "K": d.K.tolist(),
        "closed_loop_poles_real": np.sort(d.poles.real).tolist(),
        "closed_loop_hurwitz": d.hurwitz,
        "care_residual": d.care_residual,
    }
    if d.n_joints is not None:
        record.update(zip(("K_I", "K_P", "K_D"), (k.tolist() for k in d.pid_matrices())))
    certificate: Any
    if not system.interval_elements:  # a polytope: the exact test at its vertices
        certificate = vertex_certificate(model, d)
        record.update(max_eig_Z=None, certified=certificate.certified, vertex_test=certificate.message)
    else:
        certificate = certify(model, d, elements)
        record.update(max_eig_Z=certificate.max_eig, certified=certificate.certified,
                      lyapunov_residual=certificate.lyapunov_residual,
                      contributions=certificate.contributions().to_dict(orient="records"))
    return DesignAnswer(d, certificate, record)
