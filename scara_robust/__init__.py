"""Robust PID design for SCARA robots carrying a time-varying payload.

Use as ``import scara_robust as sr``.

Robot (:mod:`scara_robust.robot`)
    ScaraParams, paper_params       -- robot data (SI), the paper's by default
    SinusoidalPayload, ConstantPayload, paper_payload -- payload mass profiles m_p(t)
    mass_matrix, coriolis, forward_dynamics, kinetic_energy -- Eq. (1)
    error_dynamics_jacobians        -- linearized error dynamics (Eq. 3)
    scara_plant                     -- the robot as a control.NonlinearIOSystem
Signals (:mod:`scara_robust.signals`)
    Reference, paper_reference, sinusoidal_reference -- joint references with derivatives
    SquareWave, paper_disturbance   -- square-wave disturbance torques
Uncertain model (:mod:`scara_robust.uncertain`)
    UncertainElement, UncertainLTVModel -- ẋ = (A + ΔA)x + (B + ΔB)u with interval elements
    paper_model, derived_model      -- published bounds / bounds derived from the robot
Design and certificate (:mod:`scara_robust.design`, :mod:`scara_robust.certificate`)
    design, Design                  -- K from (ρ, η), procedure steps 2-3
    certify, Certificate, UltimateBound -- Theorem 1 and Corollary 1
Beyond Theorem 1 (:mod:`scara_robust.vertices`, :mod:`scara_robust.lmi`, :mod:`scara_robust.falsifier`)
    vertex_certificate, physical_certificate, PolytopeCertificate -- exact test of P over a polytope
    box_vertices, box_closed_loops, polytope_certificate -- the box's corners and closed loops
    physical_samples, PhysicalSamples -- the robot's own (A, B) along the reference
    lmi_certificate, LMICertificate, verify_lyapunov -- common quadratic P by SDP (extra ``lmi``)
    falsify, FalsifierResult        -- search for a destabilizing switching signal
    certificate_table, CERTIFICATE_METHODS -- every certificate of one design (``certify`` command)
Design surface (:mod:`scara_robust.surface`)
    design_surface, DesignSurface   -- max λ(Z) over a (ρ, η) grid (Figure 2)
Simulation (:mod:`scara_robust.controllers`, :mod:`scara_robust.simulation`)
    pid_controller, sliding_mode_controller, SlidingModeGains, CONTROLLERS, make_controller
    simulate, run_scenario, SimulationResult, Scenario, SCENARIOS, closed_loop
Campaigns (:mod:`scara_robust.campaign`)
    load_spec, CampaignSpec, CampaignSpecError -- Monte-Carlo campaign specs (TOML)
    run_campaign, read_results, campaign_report -- run (local or Dask), resume, summarize
Metrics and comparison (:mod:`scara_robust.metrics`, :mod:`scara_robust.comparison`)
    tracking_metrics, TrackingMetrics -- errors and torques after the transient
    compare_controllers             -- the PID vs sliding-mode table (``python -m scara_robust.compare``)
Plotting (:mod:`scara_robust.plotting`)
    plot_surface, plot_surface_contour, plot_response, plot_signals, plot_campaign
Reproduction (:mod:`scara_robust.reproduction`)
    reproduction_table              -- the paper's claims next to the package's results
    PAPER_GAIN, PAPER_DESIGN_POINT  -- K and (ρ*, η*) as printed in Section 4
"""

from .campaign import CampaignSpec, CampaignSpecError, campaign_report, load_spec, read_results, run_campaign
from .certificate import Certificate, UltimateBound, certify
from .comparison import compare_controllers
from .conservatism import CERTIFICATE_METHODS, certificate_table
from .controllers import CONTROLLERS, SlidingModeGains, make_controller, pid_controller, sliding_mode_controller
from .design import Design, design
from .falsifier import FalsifierResult, falsify
from .lmi import LMICertificate, lmi_certificate, verify_lyapunov
from .metrics import TrackingMetrics, tracking_metrics
from .plotting import plot_campaign, plot_response, plot_signals, plot_surface, plot_surface_contour
from .reproduction import PAPER_DESIGN_POINT, PAPER_GAIN, reproduction_table
from .robot import (
    ConstantPayload,
    ScaraParams,
    SinusoidalPayload,
    coriolis,
    error_dynamics_jacobians,
    forward_dynamics,
    kinetic_energy,
    mass_matrix,
    paper_params,
    paper_payload,
    scara_plant,
)
from .signals import Reference, SquareWave, paper_disturbance, paper_reference, sinusoidal_reference
from .simulation import SCENARIOS, Scenario, SimulationResult, closed_loop, run_scenario, simulate
from .surface import DesignSurface, design_surface
from .uncertain import (
    PhysicalSamples,
    UncertainElement,
    UncertainLTVModel,
    derived_model,
    paper_model,
    physical_samples,
)
from .vertices import (
    PolytopeCertificate,
    box_closed_loops,
    box_vertices,
    physical_certificate,
    polytope_certificate,
    vertex_certificate,
)

__all__ = [
    "CERTIFICATE_METHODS",
    "CONTROLLERS",
    "CampaignSpec",
    "CampaignSpecError",
    "Certificate",
    "ConstantPayload",
    "Design",
    "DesignSurface",
    "FalsifierResult",
    "LMICertificate",
    "PAPER_DESIGN_POINT",
    "PAPER_GAIN",
    "PhysicalSamples",
    "PolytopeCertificate",
    "Reference",
    "SCENARIOS",
    "ScaraParams",
    "Scenario",
    "SimulationResult",
    "SinusoidalPayload",
    "SlidingModeGains",
    "SquareWave",
    "TrackingMetrics",
    "UltimateBound",
    "UncertainElement",
    "UncertainLTVModel",
    "box_closed_loops",
    "box_vertices",
    "campaign_report",
    "certificate_table",
    "certify",
    "closed_loop",
    "compare_controllers",
    "coriolis",
    "derived_model",
    "design",
    "design_surface",
    "error_dynamics_jacobians",
    "falsify",
    "forward_dynamics",
    "kinetic_energy",
    "lmi_certificate",
    "load_spec",
    "make_controller",
    "mass_matrix",
    "paper_disturbance",
    "paper_model",
    "paper_params",
    "paper_payload",
    "paper_reference",
    "physical_certificate",
    "physical_samples",
    "pid_controller",
    "plot_campaign",
    "plot_response",
    "plot_signals",
    "plot_surface",
    "plot_surface_contour",
    "polytope_certificate",
    "read_results",
    "reproduction_table",
    "run_campaign",
    "run_scenario",
    "scara_plant",
    "simulate",
    "sinusoidal_reference",
    "sliding_mode_controller",
    "tracking_metrics",
    "verify_lyapunov",
    "vertex_certificate",
]
__version__ = "0.1.0"
