"""Turn a pytest-benchmark JSON report into the performance page's table (docs/performance.md).

Usage: ``python benchmarks/report.py benchmark.json``. Prints a markdown table of mean
times and the ratios of each reference to its fast counterpart, measured in the same run.
"""

from __future__ import annotations

import json
import sys


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        sys.stderr.write("usage: python benchmarks/report.py BENCHMARK.json\n")
        return 2
    with open(argv[0], encoding="utf-8") as fh:
        report = json.load(fh)
    mean = {b["name"]: b["stats"]["mean"] for b in report["benchmarks"]}
    info = report.get("machine_info", {})
    lines = [
        f"machine: {info.get('cpu', {}).get('brand_raw', '?')}, {info.get('cpu', {}).get('count', '?')} cores, "
        f"Python {info.get('python_version', '?')}",
        "",
        "| benchmark | fast [s] | reference [s] | ratio |",
        "|---|---|---|---|",
    ]
    pairs = [
        ("surface 50x50 (2 500 points)", "test_surface[50x50-structured]", "test_surface[50x50-reference]"),
        ("surface 200x200 (40 000 points)", "test_surface[200x200-structured]", "test_surface[200x200-reference]"),
        ("PID 20-s run", "test_simulation_pid_20s[lsoda]", "test_simulation_pid_20s[interconnect]"),
    ]
    for label, fast, ref in pairs:
        if fast in mean and ref in mean:
            lines.append(f"| {label} | {mean[fast]:.4g} | {mean[ref]:.4g} | {mean[ref] / mean[fast]:.0f}x |")
    lsoda, fast = mean.get("test_simulation_pid_20s[lsoda]"), mean.get("test_simulation_pid_20s[compiled]")
    if lsoda and fast:
        lines.append(f"| PID 20-s run, compiled vs lsoda | {fast:.4g} | {lsoda:.4g} | {lsoda / fast:.0f}x |")
    extra = {b["name"]: b.get("extra_info", {}) for b in report["benchmarks"]}
    for integrator in ("bdf", "dopri5"):
        name = f"test_compiled_integrators[{integrator}]"
        if name in mean:
            calls = extra[name]["rhs_calls"]
            lines.append(f"| compiled kernel, {integrator}: {calls} right-hand-side calls, "
                         f"{mean[name] / calls * 1e9:.0f} ns per call | {mean[name]:.4g} | | |")
    rates = {}
    for engine in ("compiled", "scipy"):
        name = f"test_campaign_throughput[{engine}]"
        if name in mean:
            rates[engine] = extra[name]["scenarios"] / mean[name]
    if len(rates) == 2:
        lines.append(f"| campaign, 2 workers [scenarios/s] | {rates['compiled']:.3g} | {rates['scipy']:.3g} | "
                     f"{rates['compiled'] / rates['scipy']:.0f}x |")
    arm_campaign = "test_arm6_campaign_throughput"
    if arm_campaign in mean:
        info = extra[arm_campaign]
        rate = info["scenarios"] / mean[arm_campaign]
        lines.append(f"| campaign on the 6-joint arm, 2 workers, {info['scenarios']} scenarios of 10 s "
                     f"({info['tracking']} tracking) [scenarios/s] | {rate:.3g} | | |")
    compile_s = extra.get("test_simulation_pid_20s[compiled]", {}).get("compile_seconds")
    if compile_s is not None:
        lines.append(f"| compiled engine: load from the disk cache, once per process | {compile_s:.3g} | | |")
    if "test_compare" in mean:
        lines.append(f"| whole `compare` (8 runs) | {mean['test_compare']:.3g} | | |")
    plain = mean.get("test_surface[50x50-structured]")
    for label, name in (
        ("margin map 50x50, Theorem 1 (vs the plain 50x50 surface)", "test_margin_map_theorem1"),
        ("margin map 50x50, vertex (1024 vertices per point)", "test_margin_map_vertex"),
        ("vertex margin, one design", "test_margin_vertex_one_point"),
    ):
        if name in mean:
            ratio = f"{mean[name] / plain:.1f}x the plain surface" if plain and "map" in name else ""
            lines.append(f"| {label} | {mean[name]:.4g} | | {ratio} |")
    if "test_scara_margin_command" in mean:
        lo, hi = extra["test_scara_margin_command"].get("bracket", [float("nan")] * 2)
        lines.append(f"| `margin --rho 3 --eta 90` after start-up, every row (bracket [{lo:.6g}, {hi:.6g}]) | "
                     f"{mean['test_scara_margin_command']:.3g} | | |")
    api = mean.get("test_startup[api]")
    for what, label in (("import", "`import scara_robust`"), ("help", "`python -m scara_robust --help`")):
        name = f"test_startup[{what}]"
        if name in mean and api:
            lines.append(f"| start-up, a new process: {label} (vs the whole API imported) | {mean[name]:.3g} | "
                         f"{api:.3g} | {api / mean[name]:.0f}x |")
    arm = "test_arm6_run_20s"
    if arm in mean:
        info = extra[arm]
        share = info["pinocchio_seconds"] / info["timed_seconds"]
        lines.append(f"| 6-joint arm, 20-s run ({info['pinocchio_calls']} Pinocchio calls; {share:.0%} of the time "
                     f"in Pinocchio, the rest in Python and scipy) | {mean[arm]:.4g} | | |")
    arm_lsoda = mean.get("test_arm6_compiled_vs_lsoda_20s[lsoda]")
    arm_compiled = mean.get("test_arm6_compiled_vs_lsoda_20s[compiled]")
    if arm_lsoda and arm_compiled:
        diff = extra["test_arm6_compiled_vs_lsoda_20s[compiled]"].get("max_abs_error_difference [rad]", float("nan"))
        lines.append(f"| 6-joint arm, 20-s run, compiled (BDF) vs lsoda (max \\|e\\| after 6 s differs by "
                     f"{diff:.1g} rad) | {arm_compiled:.4g} | {arm_lsoda:.4g} | {arm_lsoda / arm_compiled:.1f}x |")
    own, clarabel = "test_arm6_sampled_lmi_solve[ipm]", "test_arm6_sampled_lmi_solve[clarabel]"
    if own in mean and clarabel in mean:
        info, ref = extra[own], extra[clarabel]
        lines.append(f"| 6-joint arm, sampled-data LMI at Ts = 1 ms on {info['plants']} plants of {info['states']} "
                     f"states, one solve to the optimum, the package's solver vs cvxpy + Clarabel (numpy's check "
                     f"included; decay rates {info['rate']:.4g} and {ref['rate']:.4g} 1/s) | {mean[own]:.3g} | "
                     f"{mean[clarabel]:.3g} | {mean[clarabel] / mean[own]:.0f}x |")
    scan, eig = mean.get("test_arm6_frozen_scan[scan]"), mean.get("test_arm6_frozen_scan[eigenvalues]")
    if scan and eig:
        info = extra["test_arm6_frozen_scan[scan]"]
        lines.append(f"| 6-joint arm, the frozen payload search's first {info['scales']} scales of {info['loops']} "
                     f"closed loops: kept Lyapunov matrices vs every eigenvalue (the same answers) | {scan:.3g} | "
                     f"{eig:.3g} | {eig / scan:.1f}x |")
    click, riccati = mean.get("test_app_click_to_gain"), mean.get("test_app_click_to_gain_reference")
    if click and riccati:
        lines.append(f"| design page: a click's K and Theorem 1 (vs the Riccati design alone) | {click:.4g} | "
                     f"{riccati:.4g} | {click / riccati:.1f}x |")
    if "test_app_response" in mean:
        lines.append(f"| design page: the 20-s SCARA response, compiled, warm | {mean['test_app_response']:.4g} | | |")
    page = extra.get("test_app_page_in_chromium", {})
    for key, what in (("K [ms]", "K and Theorem 1"), ("response [ms]", "the 20-s response")):
        if key in page:
            t = page[key]
            lines.append(f"| design page in Chromium, click to {what} painted ({len(t['all'])} clicks): median, "
                         f"90th percentile, largest [ms] | {t['median']:.0f} / {t['p90']:.0f} / {t['max']:.0f} | | |")
    boards = [(f"test_board_pid_step[{precision}-{robot}]", label, precision)
              for robot, label in (("scara", "SCARA PID (2 joints)"), ("arm6", "6-joint arm PID"))
              for precision in ("single", "double")]
    boards.append(("test_board_arm_pid_with_feedforward_step", "6-joint arm PID + gravity feedforward (RNEA)",
                   "double"))
    for name, label, precision in boards:
        if name in mean:
            b = extra[name]
            lines.append(
                f"| Cortex-M4F (QEMU mps2-an386), {label}, {precision}: {b['instructions mean']:.0f} instructions "
                f"per step ({b['instructions min']}-{b['instructions max']}), {b['share of Ts']:.2%} of Ts = 1 ms "
                f"(slowest step) at {b['clock [Hz]'] / 1e6:g} MHz, flash {b['flash [B]']} B, "
                f"RAM {b['RAM [B]']} B; the time: compile and emulate 10⁴ steps | {mean[name]:.3g} | | |")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
