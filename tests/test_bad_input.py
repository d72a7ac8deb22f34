"""Bad-input corpus: every public entry point refuses malformed input with a clear error.

Each API case names the callable, the exception type and a pattern that must appear in
the message (the argument's name in backticks). Each CLI case checks exit code 2, one
line on stderr, no traceback, and no file left behind.
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.studies.campaign.inputs import fixed_inputs, run_arguments
from scara_robust.studies.campaign.report import wilson_interval

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PAPER = sr.paper_model()
DESIGN = sr.design(PAPER, 3.0, 90.0)
SWITCHED = np.array([[[-0.1, 1.0], [-10.0, -0.1]], [[-0.1, 10.0], [-1.0, -0.1]]])

API_CASES = [
    # robot data
    ("params-negative-mass", lambda: sr.ScaraParams(m1=-1.0), ValueError, r"`m1 \[kg\]`"),
    ("params-zero-length", lambda: sr.ScaraParams(L1=0.0), ValueError, r"`L1 \[m\]`"),
    ("params-nan", lambda: sr.ScaraParams(I2=float("nan")), ValueError, r"`I2"),
    ("params-string", lambda: sr.ScaraParams(m2="heavy"), TypeError, r"`m2"),
    ("payload-negative", lambda: sr.ConstantPayload(-0.5), ValueError, r"mass"),
    ("payload-omega", lambda: sr.SinusoidalPayload(1.0, 0.5, omega=0.0), ValueError, r"`omega \[rad/s\]`"),
    ("square-period", lambda: sr.SquareWave(period=-1.0), ValueError, r"`period \[s\]`"),
    ("square-signs-shape", lambda: sr.SquareWave(signs=()), ValueError, r"`signs`"),
    ("square-signs-joints",
     lambda: sr.simulate("pid", "small", t_final=0.1, disturbance=sr.SquareWave(signs=(1, 1, 1))),
     ValueError, r"`disturbance`"),
    ("reference-not-callable", lambda: sr.Reference(1.0, np.sin, np.cos), TypeError, r"`position`"),
    ("mass-matrix-shape", lambda: sr.mass_matrix(sr.ScaraParams(), np.zeros(3), 0.0), ValueError, r"`q` must"),
    # uncertain model
    ("element-matrix", lambda: sr.UncertainElement("C", 0, 0, 0.0, 1.0), ValueError, r"`matrix`"),
    ("element-lower>upper", lambda: sr.UncertainElement("A", 0, 0, 1.0, 0.0), ValueError, r"`lower`|`upper`"),
    ("element-outside",
     lambda: sr.UncertainLTVModel(np.eye(2), np.ones((2, 1)), (sr.UncertainElement("A", 5, 0, 0, 1),)),
     ValueError, r"outside|row"),
    ("model-A-not-square", lambda: sr.UncertainLTVModel(np.ones((2, 3)), np.ones((2, 1)), ()), ValueError, r"`A`"),
    ("model-A-inf", lambda: sr.UncertainLTVModel(np.array([[np.inf, 0], [0, 1.0]]), np.ones((2, 1)), ()),
     ValueError, r"`A`"),
    ("derived-n-masses", lambda: sr.derived_model(n_masses=0), ValueError, r"`n_masses`"),
    ("derived-times-empty", lambda: sr.derived_model(times=[]), ValueError, r"`times`"),
    # design and certificate
    ("design-rho-zero", lambda: sr.design(PAPER, 0.0, 90.0), ValueError, r"`rho`"),
    ("design-eta-small", lambda: sr.design(PAPER, 3.0, 0.5), ValueError, r"`eta`"),
    ("design-rho-nan", lambda: sr.design(PAPER, float("nan"), 90.0), ValueError, r"`rho`"),
    ("design-rho-string", lambda: sr.design(PAPER, "3", 90.0), TypeError, r"`rho`"),
    ("design-model-type", lambda: sr.design("paper", 3.0, 90.0), TypeError, r"`model`"),
    ("design-not-stabilizable", lambda: sr.design(sr.UncertainLTVModel(np.eye(2), np.zeros((2, 1)), ()), 1.0, 2.0),
     ValueError, r"stabilizable"),
    # (1e12 and 1e-12 are solved since care's answer is refined by Newton steps, to scipy's within 1e-8)
    ("design-rho-huge", lambda: sr.design(PAPER, 1e14, 90.0), ValueError, r"`rho`=1e\+14: the Riccati solution is "
     r"inaccurate .relative residual [0-9.e+-]+ > 1e-06 after 3 Newton steps"),
    ("design-rho-tiny", lambda: sr.design(PAPER, 1e-20, 90.0), ValueError, r"`rho`=1e-20: the Riccati equation of "
     r"step 2 has no stabilizing solution"),
    ("surface-rho-huge", lambda: sr.design_surface(PAPER, [1.0, 1e14], [1.0]), ValueError, r"`rho`=1e\+14"),
    ("certify-eta-huge", lambda: sr.certify(PAPER, sr.design(PAPER, 3.0, 1e15)), ValueError, r"beyond what double"),
    ("certify-elements", lambda: sr.certify(PAPER, DESIGN, "C"), ValueError, r"`elements`"),
    ("certify-design-type", lambda: sr.certify(PAPER, "K"), TypeError, r"`design`"),
    ("surface-rhos-negative", lambda: sr.design_surface(PAPER, [-1.0, 1.0], [1.0]), ValueError, r"`rhos`"),
    ("surface-etas-empty", lambda: sr.design_surface(PAPER, [1.0], []), ValueError, r"`etas`"),
    ("surface-method", lambda: sr.design_surface(PAPER, [1.0], [1.0], formulation="fast"), ValueError,
     r"`formulation`"),
    ("surface-2d-grid", lambda: sr.design_surface(PAPER, [[1.0]], [1.0]), ValueError, r"`rhos`"),
    # beyond Theorem 1
    ("vertex-elements", lambda: sr.vertex_certificate(PAPER, DESIGN, "all-of-them"), ValueError, r"`elements`"),
    ("polytope-P-shape", lambda: sr.polytope_certificate(SWITCHED, np.eye(3)), ValueError, r"`P`"),
    ("polytope-P-asymmetric", lambda: sr.polytope_certificate(SWITCHED, [[1.0, 0.5], [0.0, 1.0]]), ValueError,
     r"`P` must be symmetric"),
    ("falsify-P-asymmetric", lambda: sr.falsify(SWITCHED, [[1.0, 0.5], [0.0, 1.0]]), ValueError,
     r"`P` must be symmetric"),
    ("lmi-solver", lambda: sr.lmi_certificate(SWITCHED, solver="MOSEK"), ValueError, r"`solver`"),
    ("lmi-shape", lambda: sr.lmi_certificate(np.eye(2)), ValueError, r"`closed_loops`"),
    ("falsify-dwell", lambda: sr.falsify(SWITCHED, dwell=-1.0), ValueError, r"`dwell`"),
    ("physical-n-times", lambda: sr.physical_certificate(DESIGN, n_times=0), ValueError, r"`n_times`"),
    # simulation
    ("simulate-controller", lambda: sr.simulate("lqr"), ValueError, r"`controller`"),
    ("simulate-scenario", lambda: sr.simulate("pid", "medium"), ValueError, r"`scenario`"),
    ("simulate-t-final", lambda: sr.simulate("pid", t_final=0.0), ValueError, r"`t_final"),
    ("simulate-x0-nan", lambda: sr.simulate("pid", x0=[np.nan] * 6), ValueError, r"`x0`"),
    ("simulate-method", lambda: sr.simulate("pid", method="euler"), ValueError, r"`method`"),
    ("pid-K-shape", lambda: sr.pid_controller(np.ones((6, 2))), ValueError, r"`K`"),
    ("torque-limit-negative", lambda: sr.make_controller("pid", torque_limit=-1.0), ValueError, r"`torque_limit"),
    ("metrics-short", lambda: sr.tracking_metrics(np.linspace(0, 1, 5), np.zeros((2, 5)), np.zeros((2, 5))),
     ValueError, r"`t`"),
    ("compare-controller", lambda: sr.compare_controllers(["pid", "lqr"], t_final=7.0), ValueError, r"`controller`"),
    # discrete PID, sampled-data certificate, export
    ("discretize-ts-zero", lambda: DESIGN.discretize(0.0), ValueError, r"`Ts` must be > 0"),
    ("discretize-tt-zero", lambda: DESIGN.discretize(1e-3, tracking_time=0.0), ValueError,
     r"`tracking_time` must be > 0"),
    ("discretize-limit-zero", lambda: DESIGN.discretize(1e-3, torque_limit=0.0), ValueError,
     r"`torque_limit` must be > 0"),
    ("pid-step-shape", lambda: DESIGN.discretize(1e-3).step([0.1], [0.0]), ValueError, r"`e` must have shape"),
    ("pid-step-edot", lambda: DESIGN.discretize(1e-3).step([0.1, 0.0]), ValueError, r"`edot` is required"),
    ("max-ts-rtol", lambda: sr.max_sample_time(PAPER, DESIGN, rtol=0.0), ValueError, r"`rtol` must be > 0"),
    ("export-format", lambda: sr.export_controller(DESIGN.discretize(1e-3), ".", format="rust"), ValueError,
     r"`format` must be one of"),
    ("sampled-pid-type", lambda: sr.sampled_pid_controller(DESIGN), ValueError, r"`pid` must be a DiscretePID"),
    # reproduction, plotting, campaigns
    ("reproduction-type", lambda: sr.reproduction_table([1, 2]), TypeError, r"`comparison`"),
    ("plot-signals-empty", lambda: sr.plot_signals([]), ValueError, r"`results`"),
    ("campaign-spec-type", lambda: sr.run_campaign("spec.toml", "r.csv"), TypeError, r"`spec`"),
    ("campaign-report-frame", lambda: sr.campaign_report(np.zeros(3)), ValueError, r"`results`"),
    ("campaign-report-confidence", lambda: wilson_interval(1, 10, confidence=95), ValueError, r"`confidence`"),
    ("worst-frame", lambda: sr.worst_scenarios([1, 2]), ValueError, r"`results`"),
    ("replay-frame", lambda: sr.replay_scenario(pd.DataFrame({"scenario": [0], "controller": ["pid"]}), 0),
     ValueError, r"`results` lacks the inputs needed to replay"),
    ("run-arguments-missing", lambda: run_arguments({"scenario": 0}), ValueError, r"`inputs` lacks"),
    # sizes, refused up front with the memory they would need
    ("simulate-t-final-huge", lambda: sr.run_scenario("pid", "small", t_final=1e7), ValueError,
     r"`t_final` asks for 1e\+10 output samples .* of memory"),
    ("box-corners-huge", lambda: sr.UncertainLTVModel(np.zeros((8, 8)), np.ones((8, 1)), [
        sr.UncertainElement("A", k // 8, k % 8, -1e-3, 0.0) for k in range(60)]).box_vertices(), ValueError,
     r"`model` asks for the 2\^60 = 1.15e\+18 corners of its box"),
    # deployment and answers
    ("discretize-torque-limit-count", lambda: DESIGN.discretize(1e-3, torque_limit=[50, 50, 50]), ValueError,
     r"`torque_limit` must be one value or one per torque \(2\), found 3 values"),
    ("check-sample-time-pid", lambda: sr.check_sample_time(PAPER, "pid"), TypeError, r"`pid`"),
    ("margin-anchor", lambda: sr.robustness_margin(PAPER, DESIGN, "vertex", anchor="middle"), ValueError,
     r"`anchor` must be one of"),
    ("margin-anchor-elements", lambda: sr.robustness_margin(PAPER, DESIGN, "vertex", anchor="center", elements="A"),
     ValueError, r"`elements` must be 'all' with anchor 'center'"),
]


@pytest.mark.parametrize(("call", "error", "match"), [c[1:] for c in API_CASES], ids=[c[0] for c in API_CASES])
def test_api_refuses_bad_input(call, error, match):
    with pytest.raises(error, match=match):
        call()


def _cli_cases(tmp):
    long_spec = tmp / "long.toml"
    long_spec.write_text('controllers = ["pid"]\nt_final = 1e7\nrho = 3.0\neta = 90.0\nruns = 1\nseed = 1\n')
    bad_toml = tmp / "bad.toml"
    bad_toml.write_text("[robot\nm1 = 1\n")
    unknown = tmp / "unknown.toml"
    robot_text = (EXAMPLES / "robot-paper.toml").read_text()
    unknown.write_text(robot_text.replace("\n[robot]\n", "\n[robot]\ncolour = 'red'\n"))
    negative = tmp / "negative.toml"
    negative.write_text((EXAMPLES / "robot-paper.toml").read_text().replace("m1 = 2.61", "m1 = -2.61"))
    typed = tmp / "typed.toml"
    typed.write_text((EXAMPLES / "robot-paper.toml").read_text().replace("L2 = 0.4", 'L2 = "long"'))
    scen = tmp / "scen.toml"
    scen.write_text("[disturbance]\nperiod = 0.0\n")
    pair = tmp / "pair.toml"
    pair.write_text("[initial]\ne0 = [0.1]\n")
    folder = tmp / "folder.toml"
    folder.mkdir()
    heavy = tmp / "heavy.toml"
    heavy.write_text((EXAMPLES / "robot-paper.toml").read_text().replace("m2 = 3.45", "m2 = 1e30"))
    outside = tmp / "outside.toml"
    outside.write_text((EXAMPLES / "robot-paper.toml").read_text().replace("Lc1 = 0.178", "Lc1 = 5.0"))
    empty = tmp / "empty.toml"
    empty.write_text("")
    wide = tmp / "wide.json"
    wide.write_text('{"format": "scara_robust design 1", "K": [[1.0, 2.0, 3.0]]}')
    foreign = tmp / "foreign.json"
    foreign.write_text('{"K": [[1.0]]}')
    spec = sr.spec_from_dict({"controllers": ["pid"], "t_final": 6.5})
    row = {**sr.draw_scenario(spec, 0, 0), **fixed_inputs(spec), "controller": "pid", "status": "tracking",
           "success": True, "diverged": False, "error": "", "status_reason": "", "seed": 0, "spec": spec.digest()}
    table = tmp / "table.csv"
    pd.DataFrame([{**row, **dict.fromkeys(sr.METRIC_NAMES, 0.01)}]).to_csv(table, index=False)
    replay = ["simulate", "--from-campaign", str(table)]
    campaign_text = (EXAMPLES / "campaign.toml").read_text()
    open_range = tmp / "open.toml"
    open_range.write_text(campaign_text.replace("torque_limit = inf", "torque_limit = { min = 5.0, max = inf }"))
    nan_rho = tmp / "nan.toml"
    nan_rho.write_text(campaign_text.replace("rho = 3.0", "rho = nan"))
    k_and_p = tmp / "kp.json"
    k_and_p.write_text(json.dumps({"format": "scara_robust design 1", "K": np.ones((2, 5)).tolist(),
                                   "P": np.eye(6).tolist()}))
    design = ["design", "--rho", "3", "--eta", "90"]
    export = ["export", "--rho", "3", "--eta", "90"]
    return [
        ("design-rho-negative", ["design", "--rho=-3", "--eta", "90"], "`--rho`"),
        ("design-eta-huge", ["design", "--rho", "3", "--eta", "1e15"], "Lyapunov equation"),
        ("design-rho-text", ["design", "--rho", "three", "--eta", "90"], "expected a number"),
        ("design-eta-inf", ["design", "--rho", "3", "--eta", "inf"], "finite"),
        ("design-missing-eta", ["design", "--rho", "3"], "--eta"),
        ("design-format", [*design, "--format", "xml"], "invalid choice"),
        ("surface-range", ["surface", "--rho", "1:2", "--eta", "1:2:3"], "START:STOP:NUM"),
        ("surface-range-num", ["surface", "--rho", "1:2:0", "--eta", "1:2:3"], "NUM must be >= 1"),
        ("unknown-command", ["optimize"], "invalid choice"),
        ("robot-missing", [*design, "--robot", str(tmp / "none.toml")], "`--robot`"),
        ("robot-directory", [*design, "--robot", str(folder)], "is a directory"),
        ("robot-bad-toml", [*design, "--robot", str(bad_toml)], "not valid TOML"),
        ("robot-unknown-field", [*design, "--robot", str(unknown)], "unknown field `robot.colour`"),
        ("robot-negative-mass", [*design, "--robot", str(negative)], "field `robot.m1` [kg] must be > 0"),
        ("robot-wrong-type", [*design, "--robot", str(typed)], "`robot.L2` must be a finite number in m"),
        ("robot-extension", [*design, "--robot", str(tmp / "robot.yaml")], "expected a .toml or .json file"),
        ("scenario-name", ["simulate", "--scenario", "medium"], "`--scenario` must be 'large', 'small'"),
        ("scenario-period", ["simulate", "--scenario", str(scen)], "period [s]"),
        ("scenario-pair", ["simulate", "--scenario", str(pair)], "`initial.e0` must be a pair"),
        ("simulate-t-final", ["simulate", "--t-final", "0"], "`--t-final`"),
        ("simulate-torque-limit", ["simulate", "--torque-limit", "-1"], "`--torque-limit`"),
        ("compare-t-final", ["compare", "--t-final", "5"], "`--t-final` must be > 6 s"),
        ("certify-tries", ["certify", "--rho", "3", "--eta", "90", "--tries", "0"], "`--tries`"),
        ("output-directory", [*design, "--output", str(tmp)], "is a directory"),
        ("output-missing-folder", [*design, "--output", str(tmp / "no" / "such" / "k.json")], "No such file"),
        ("output-unwritable", [*design, "--output", "/proc/scara_robust_k.json"], "scara_robust: error"),
        ("plot-unwritable", ["simulate", "--t-final", "0.2", "--plot", "/proc/x.png"], "scara_robust: error"),
        ("report-missing", ["campaign-report", str(tmp / "none.csv")], "No such file"),
        ("surface-huge-grid", ["surface", "--rho", "0.1:10:100000", "--eta", "1:200:100000"],
         "`--rho` x `--eta` is a grid of 10,000,000,000 points (about 8.64e+03 GB of memory)"),
        ("surface-num-1", ["surface", "--rho", "1:10:1", "--eta", "1:2:2"], "NUM = 1 would keep START alone"),
        ("surface-mark-alone", ["surface", "--rho", "1:2:2", "--eta", "1:2:2", "--mark", "1,2"], "`--mark`"),
        ("robot-heavy", [*design, "--robot", str(heavy)], "field `robot.m2` [kg] must be <= 1000 kg"),
        ("robot-com-outside", [*design, "--robot", str(outside)], "field `robot.Lc1` [m] must be <= L1 = 0.3 m"),
        ("report-not-a-table", ["campaign-report", str(EXAMPLES / "campaign.toml")],
         "`RESULTS` must end in .csv or .parquet"),
        ("simulate-output-folder", ["simulate", "--output", str(tmp / "no" / "dir" / "x.csv")],
         f"`--output` {str(tmp / 'no' / 'dir' / 'x.csv')!r}: No such file or directory"),
        ("design-scenario", [*design, "--scenario", "small"], "unrecognized arguments: --scenario small"),
        ("design-scenario-file", [*design, "--scenario", str(EXAMPLES / "scenario-paper.toml")],
         "unrecognized arguments: --scenario"),
        ("certify-named-scenario", ["certify", "--rho", "3", "--eta", "90", "--scenario", "small"],
         "means nothing for this command"),
        ("typo", [*design, "--elemnts", "A"], "design: unrecognized arguments: --elemnts A; did you mean --elements?"),
        ("campaign-empty-spec", ["campaign", str(empty), "--output", str(tmp / "r.csv")], "is empty"),
        ("campaign-checkpoint", ["campaign", str(EXAMPLES / "campaign.toml"), "--checkpoint=-1", "--output",
                                 str(tmp / "r.csv")], "`--checkpoint` must be >= 0, found -1.0"),
        ("synthesize-gain-bound", ["synthesize", "--gain-bound", "0"], "`--gain-bound` must be > 0"),
        ("synthesize-decay", ["synthesize", "--decay=-1"], "`--decay` must be >= 0 1/s"),
        ("synthesize-output-ext", ["synthesize", "--output", str(tmp / "k.txt")], "a design file is .json"),
        ("synthesize-margin-physical", ["synthesize", "--objective", "margin"], "goes with --set box"),
        ("synthesize-physical-model", ["synthesize", "--set", "physical", "--model",
                                       str(EXAMPLES / "plant-dc-motor-elements.toml")], "with --model use --set box"),
        ("design-file-shape", ["simulate", "--design", str(wide)], "field `K` must have shape (2, 6)"),
        ("design-file-format", ["compare", "--design", str(foreign)], "field `format` must be"),
        ("design-file-controller", ["simulate", "--controller", "smc", "--design",
                                    str(EXAMPLES.parent / "scara_robust" / "data" / "pid_lmi.json")],
         "it goes with --controller pid"),
        ("export-ts-zero", [*export, "--ts", "0", "--output", str(tmp)], "`--ts` must be > 0"),
        ("export-ts-negative", [*export, "--ts=-0.001", "--output", str(tmp)], "`--ts` must be > 0"),
        ("export-tt-zero", [*export, "--ts", "0.001", "--torque-limit", "50", "--tracking-time", "0",
                            "--output", str(tmp)], "`--tracking-time` must be > 0 s"),
        ("export-limit-zero", [*export, "--ts", "0.001", "--torque-limit", "50,0", "--output", str(tmp)],
         "`--torque-limit` must be > 0 N·m"),
        ("export-unwritable", [*export, "--ts", "0.001", "--output", "/proc"], "`--output` '/proc': the folder is not"),
        ("export-missing-folder", [*export, "--ts", "0.001", "--output", str(tmp / "no")], "no such folder"),
        ("export-prefix", [*export, "--ts", "0.001", "--prefix", "scara-pid", "--output", str(tmp)],
         "`--prefix` must be a C identifier"),
        ("replay-missing", ["simulate", "--from-campaign", str(tmp / "none.csv"), "--index", "0"],
         "`--from-campaign` " + repr(str(tmp / "none.csv")) + ": No such file"),
        ("replay-not-a-table", ["simulate", "--from-campaign", str(scen), "--index", "0"],
         "`--from-campaign` must end in .csv or .parquet"),
        ("replay-index", [*replay, "--index", "3"],
         "`--index` must be a scenario of the table (indices 0..0), found 3"),
        ("replay-negative-index", [*replay, "--index=-1"], "`--index` must be an integer >= 0"),
        ("replay-controller", [*replay, "--index", "0", "--controller", "smc"],
         "`--controller` must be one of the table's ['pid'], found 'smc'"),
        ("replay-no-index", replay, "`--index` is needed with --from-campaign"),
        ("replay-index-alone", ["simulate", "--index", "0"], "`--index` picks a run of a campaign table"),
        ("replay-input-option", [*replay, "--index", "0", "--scenario", "small"],
         "--scenario cannot go with it"),
        ("simulate-method", ["simulate", "--method", "euler"], "argument --method: invalid choice"),
        # sizes: every one refused up front, naming the option and the memory it would need
        ("simulate-t-final-huge", ["simulate", "--t-final", "1e7"], "`--t-final` asks for 1e+10 output samples"),
        ("compare-t-final-huge", ["compare", "--t-final", "1e7"], "`--t-final` asks for 1e+10 output samples"),
        ("campaign-runs-huge", ["campaign", str(EXAMPLES / "campaign.toml"), "--runs", "100000000000", "--output",
                                str(tmp / "r.csv")], "`--runs` asks for a table of 200,000,000,000 runs"),
        ("campaign-t-final-huge", ["campaign", str(long_spec), "--output", str(tmp / "r.csv")],
         "`spec` asks for 1 run(s) at once of t_final = 1e+07 s each"),
        ("replay-t-final-huge", [*replay, "--index", "0", "--t-final", "1e7"], "`--t-final` asks for"),
        # answers that are not safe to act on are refused
        ("export-uncertified-ts", [*export, "--ts", "0.1", "--output", str(tmp)],
         "the largest certified Ts is"),
        ("export-design-and-rho", ["export", "--design", str(wide), "--rho", "3", "--ts", "0.001", "--output",
                                   str(tmp)], "`--design` gives the gain; it cannot go with --rho/--eta"),
        ("export-no-gain", ["export", "--ts", "0.001", "--output", str(tmp)], "give the gain"),
        ("export-torque-limit-count", [*export, "--ts", "0.001", "--torque-limit", "50,50,50", "--output", str(tmp)],
         "`--torque-limit` must be one value or one per torque (2), found 3 values"),
        ("export-tracking-time-count", [*export, "--ts", "0.001", "--torque-limit", "50", "--tracking-time", "1,2,3",
                                        "--output", str(tmp)], "`--tracking-time` must be one value or one per"),
        ("simulate-torque-limit-count", ["simulate", "--torque-limit", "50,50,50"], "`--torque-limit` must be one"),
        ("plot-jpg", ["simulate", "--plot", str(tmp / "s.jpg")], "the format follows the extension"),
        ("surface-mark-outside", ["surface", "--rho", "1:5:3", "--eta", "1:200:3", "--plot", str(tmp / "s.png"),
                                  "--mark", "50,90"], "`--mark` rho = 50 is outside the --rho grid [1, 5]"),
        ("typo-before-missing", ["design", "--rho", "3", "--etta", "90"],
         "design: unrecognized arguments: --etta 90; did you mean --eta?"),
        ("margin-anchor-elements", ["margin", "--rho", "3", "--eta", "90", "--anchor", "center", "--elements", "A"],
         "`--anchor center` scales every element"),
        ("campaign-open-range", ["campaign", str(open_range), "--runs", "2", "--output", str(tmp / "o.csv")],
         "a range must have finite ends"),
        ("campaign-nan-rho", ["campaign", str(nan_rho), "--runs", "2", "--output", str(tmp / "o.csv")],
         "field `rho` must be a finite number, found nan"),
        ("campaign-spec-missing", ["campaign", str(tmp / "none.toml"), "--output", str(tmp / "o.csv")],
         "none.toml': No such file or directory"),
        ("report-missing-parquet", ["campaign-report", str(tmp / "none.parquet")],
         "none.parquet': No such file or directory"),
        ("replay-missing-parquet", [*replay[:2], str(tmp / "none.parquet"), "--index", "1"],
         "none.parquet': No such file or directory"),
        ("design-json-not-json", [*design, "--format", "json", "--output", str(tmp / "d.txt")],
         "--format json writes a design file"),
        ("design-file-extension", ["simulate", "--design", str(tmp / "d.txt")], "a design file (.json)"),
        ("design-file-k-and-p", ["certify", "--design", str(k_and_p)], "K has shape (2, 5), so P must be (5, 5)"),
        ("margin-tol-above-1", ["margin", "--rho", "3", "--eta", "90", "--tol", "2"],
         "`--tol` must be a relative tolerance in (0, 1), found 2"),
    ]




@pytest.fixture
def cli_cases(tmp_path):
    return {name: (argv, needle) for name, argv, needle in _cli_cases(tmp_path)}


CLI_NAMES = [
    "design-rho-negative", "design-eta-huge", "design-rho-text", "design-eta-inf", "design-missing-eta",
    "design-format",
    "surface-range", "surface-range-num", "unknown-command", "robot-missing", "robot-directory", "robot-bad-toml",
    "robot-unknown-field", "robot-negative-mass", "robot-wrong-type", "robot-extension", "scenario-name",
    "scenario-period", "scenario-pair", "simulate-t-final", "simulate-torque-limit", "compare-t-final",
    "certify-tries", "output-directory", "output-missing-folder", "output-unwritable", "plot-unwritable",
    "report-missing", "surface-huge-grid", "surface-num-1", "surface-mark-alone", "robot-heavy", "robot-com-outside",
    "report-not-a-table", "simulate-output-folder", "design-scenario", "design-scenario-file",
    "certify-named-scenario", "typo", "campaign-empty-spec", "campaign-checkpoint",
    "synthesize-gain-bound", "synthesize-decay",
    "synthesize-output-ext", "synthesize-margin-physical", "synthesize-physical-model", "design-file-shape",
    "design-file-format", "design-file-controller", "export-ts-zero", "export-ts-negative", "export-tt-zero",
    "export-limit-zero", "export-unwritable", "export-missing-folder", "export-prefix", "replay-missing",
    "replay-not-a-table", "replay-index",
    "replay-negative-index", "replay-controller", "replay-no-index", "replay-index-alone", "replay-input-option",
    "simulate-method", "simulate-t-final-huge", "compare-t-final-huge", "campaign-runs-huge", "campaign-t-final-huge",
    "replay-t-final-huge", "export-uncertified-ts", "export-design-and-rho", "export-no-gain",
    "export-torque-limit-count", "export-tracking-time-count", "simulate-torque-limit-count", "plot-jpg",
    "surface-mark-outside", "typo-before-missing", "margin-anchor-elements", "campaign-open-range", "campaign-nan-rho",
    "campaign-spec-missing", "report-missing-parquet", "replay-missing-parquet", "design-json-not-json",
    "design-file-extension", "design-file-k-and-p", "margin-tol-above-1",
]


@pytest.mark.parametrize("name", CLI_NAMES, ids=CLI_NAMES)
def test_cli_refuses_bad_input(capsys, tmp_path, cli_cases, name):
    argv, needle = cli_cases[name]
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("scara_robust: error:")
    assert "Traceback" not in err and needle in err
    assert "scara_robust: error: scara_robust" not in err  # the prefix once
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written, no temporary left


def test_case_lists_agree(tmp_path):
    assert [c[0] for c in _cli_cases(tmp_path)] == CLI_NAMES
    assert len(API_CASES) + len(CLI_NAMES) >= 40


def test_failed_command_keeps_an_existing_output(capsys, tmp_path):
    out = tmp_path / "k.json"
    out.write_text("precious\n")
    assert main(["design", "--rho", "3", "--eta", "0.5", "--output", str(out)]) == 2
    assert out.read_text() == "precious\n"
    assert main(["design", "--rho", "3", "--eta", "90", "--output", str(out), "--format", "json"]) == 0
    assert out.read_text().startswith("{")


def test_output_path_is_checked_before_computing(capsys, tmp_path, monkeypatch):
    # A bad --output fails at once: the simulation never starts.
    ran = []
    monkeypatch.setattr("scara_robust.cli._simulate.run_scenario", lambda *a, **k: ran.append(1))
    assert main(["simulate", "--output", str(tmp_path / "missing" / "x.csv")]) == 2
    assert ran == [] and "missing" in capsys.readouterr().err


def test_output_files_get_the_mode_of_a_normal_file(tmp_path, capsys):
    import os

    old = os.umask(0o022)
    try:
        out = tmp_path / "k.json"
        assert main(["design", "--rho", "3", "--eta", "90", "--format", "json", "--output", str(out)]) == 0
        assert (out.stat().st_mode & 0o777) == 0o644
        os.umask(0o077)
        out.unlink()
        assert main(["design", "--rho", "3", "--eta", "90", "--format", "json", "--output", str(out)]) == 0
        assert (out.stat().st_mode & 0o777) == 0o600
    finally:
        os.umask(old)


@pytest.mark.slow  # a whole certify table in a process of its own (make test-slow)
def test_no_warning_reaches_the_user_on_overflow():
    # K of (3, 1e9) makes the box's frozen vertices grow at 2e9 1/s: an overflow is a result.
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-m", "scara_robust", "certify", "--rho", "3", "--eta", "1e9", "--tries", "2"],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0 and done.stderr == ""
    assert "grows beyond 1e+300 within one dwell of 0.01 s" in done.stdout and "grew by inf" not in done.stdout


def test_version_and_examples_in_help(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out.startswith(f"scara_robust {sr.__version__}")
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "examples:" in text and "python -m scara_robust design --rho 3 --eta 90" in text
    with pytest.raises(SystemExit):
        main(["surface", "--help"])
    assert "START:STOP:NUM, NUM evenly spaced values" in capsys.readouterr().out
