"""Monte-Carlo robustness campaigns: many drawn scenarios, every controller on each.

A campaign is described by a :class:`CampaignSpec`, usually read from a TOML file
(:func:`load_spec`; ``examples/campaign.toml`` documents every field). Scenario ``i`` of
a campaign with seed ``s`` is drawn from ``numpy.random.default_rng([s, i])`` alone, so
it is the same however the campaign is split, ordered, interrupted or distributed.

:func:`run_campaign` simulates the scenarios in chunks, locally (one process, or a pool
of processes) or on a ``dask.distributed`` cluster (extra ``dask``), and rewrites the
results file atomically after every chunk, so an interrupted campaign keeps every chunk
it finished and ``resume=True`` runs only the rest. A failed run (diverged, solver error)
becomes a row with its error; it never stops the campaign.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from .controllers import CONTROLLERS, make_controller
from .metrics import METRIC_NAMES
from .robot import ConstantPayload, ScaraParams, SinusoidalPayload
from .signals import SquareWave, sinusoidal_reference
from .simulation import SAMPLE_TIMES, Scenario, simulate

__all__ = [
    "Range",
    "CampaignSpec",
    "CampaignSpecError",
    "SPEC_FIELDS",
    "SCHEDULERS",
    "PAYLOAD_PROFILES",
    "load_spec",
    "spec_from_dict",
    "draw_scenario",
    "run_draw",
    "run_campaign",
    "read_results",
    "campaign_report",
    "add_campaign_parsers",
]

#: Where :func:`run_campaign` can run.
SCHEDULERS = ("local", "dask")
#: Payload mass profiles a campaign can draw.
PAYLOAD_PROFILES = ("sinusoidal", "constant")
#: Output formats, by file extension.
_FORMATS = {".csv": "csv", ".parquet": "parquet"}


class CampaignSpecError(ValueError):
    """A campaign spec that cannot be used; the message names the field."""


@dataclass(frozen=True)
class Range:
    """A uniform distribution on ``[low, high]``; ``low == high`` is a constant."""

    low: float
    high: float

    def draw(self, rng: np.random.Generator) -> float:
        """One value (a constant consumes no randomness)."""
        return self.low if self.low == self.high else float(rng.uniform(self.low, self.high))


#: Drawn numeric fields: name -> (unit, lower limit, strict, paper's value). The limit
#: is inclusive unless ``strict``.
SPEC_FIELDS: dict[str, tuple[str, float, bool, float]] = {
    "payload_peak": ("kg", 0.0, False, 0.6 * 3.45),
    "payload_omega": ("rad/s", 0.0, True, 1.0),
    "payload_phase": ("rad", -math.inf, False, 0.0),
    "cp": ("m²", 0.0, False, 0.005),
    "disturbance_amplitude": ("N·m", 0.0, False, 5.0),
    "disturbance_period": ("s", 0.0, True, math.pi / 5),
    "disturbance_phase": ("rad", -math.inf, False, 0.0),
    "reference_amplitude": ("rad", 0.0, False, 1.0),
    "reference_omega": ("rad/s", 0.0, True, 1.0),
    "initial_error": ("rad", -math.inf, False, 0.05),
    "torque_limit": ("N·m", 0.0, True, math.inf),
}


def _default_ranges() -> dict[str, Range]:
    return {name: Range(v[3], v[3]) for name, v in SPEC_FIELDS.items()}


@dataclass(frozen=True)
class CampaignSpec:
    """What a campaign draws and runs.

    Attributes
    ----------
    controllers : tuple of str
        Names from :data:`scara_robust.CONTROLLERS` (at least one, no repeats).
    t_final : float
        Horizon of every run, s (> 6, so the after-transient metrics exist).
    rho, eta : float
        The PID design K(ρ, η) on the published model (fixed for the campaign).
    payload_profiles : tuple of str
        Drawn uniformly: ``'sinusoidal'`` is ``m_p(t) = (peak/2)(1 + sin(ωt + φ))``,
        ``'constant'`` is ``m_p = peak``.
    ranges : dict of str to Range
        One :class:`Range` per entry of :data:`SPEC_FIELDS`. ``initial_error`` is drawn
        independently for each joint (``e(0)``; ``ė(0) = 0``); ``torque_limit = inf``
        means no saturation. The reference is ``r = a (sin ωt, cos ωt)``.
    runs : int
        Default number of scenarios.
    seed : int
        Default seed.
    robot : ScaraParams
        The robot (default: the paper's); its ``cp`` is replaced by the drawn one.
    """

    controllers: tuple[str, ...] = ("pid", "smc")
    t_final: float = 20.0
    rho: float = 3.0
    eta: float = 90.0
    payload_profiles: tuple[str, ...] = ("sinusoidal",)
    ranges: Mapping[str, Range] = field(default_factory=_default_ranges)
    runs: int = 100
    seed: int = 0
    robot: ScaraParams = field(default_factory=ScaraParams)

    def digest(self) -> str:
        """Short hash of everything that determines the drawn scenarios and runs."""
        data = asdict(self)
        data.pop("runs")
        text = json.dumps(data, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:12]


def _error(name: str, message: str) -> CampaignSpecError:
    return CampaignSpecError(f"campaign spec field `{name}`: {message}")


def _number(name: str, value: Any, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _error(name, f"expected a number in {unit}, found {type(value).__name__} {value!r}")
    out = float(value)
    if math.isnan(out):
        raise _error(name, f"expected a number in {unit}, found NaN")
    return out


def _range(name: str, value: Any) -> Range:
    unit, limit, strict, _ = SPEC_FIELDS[name]
    if isinstance(value, Mapping):
        unknown = set(value) - {"min", "max"}
        if unknown or set(value) != {"min", "max"}:
            raise _error(name, f"expected a number or {{min = ..., max = ...}}, found keys {sorted(value)}")
        low, high = _number(name, value["min"], unit), _number(name, value["max"], unit)
    else:
        low = high = _number(name, value, unit)
    if low > high:
        raise _error(name, f"min {low:g} {unit} > max {high:g} {unit}")
    allow_inf = name == "torque_limit"
    for v in (low, high):
        if math.isinf(v) and not (allow_inf and v > 0):
            raise _error(name, f"expected a finite number in {unit}, found {v}")
        if (v <= limit) if strict else (v < limit):
            op = ">" if strict else ">="
            raise _error(name, f"expected values {op} {limit:g} {unit}, found {v:g}")
    return Range(low, high)


def spec_from_dict(data: Mapping[str, Any]) -> CampaignSpec:
    """Validate a campaign description (as read from TOML) into a :class:`CampaignSpec`.

    Parameters
    ----------
    data : mapping
        Field names to values: a number, ``{min, max}``, or a list for
        ``controllers`` and ``payload_profiles``.

    Returns
    -------
    CampaignSpec


    Raises
    ------
    CampaignSpecError
        Naming the first bad field: unknown field, wrong type, min > max, a value
        outside its physical range (negative mass, period <= 0, ...), an unknown or
        empty controller list.
    """
    if not isinstance(data, Mapping):
        raise CampaignSpecError(f"campaign spec must be a table of fields, found {type(data).__name__}")
    known = {"controllers", "t_final", "rho", "eta", "payload_profiles", "runs", "seed", *SPEC_FIELDS}
    for name in data:
        if name not in known:
            raise _error(name, f"unknown field; valid fields are {', '.join(sorted(known))}")
    kwargs: dict[str, Any] = {}
    if "controllers" in data:
        names = data["controllers"]
        if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
            raise _error("controllers", f"expected a list of names, found {names!r}")
        if not names:
            raise _error("controllers", f"expected at least one of {', '.join(CONTROLLERS)}, found an empty list")
        for n in names:
            if n not in CONTROLLERS:
                raise _error("controllers", f"unknown controller {n!r}; valid: {', '.join(CONTROLLERS)}")
        if len(set(names)) != len(names):
            raise _error("controllers", f"expected no repeats, found {names!r}")
        kwargs["controllers"] = tuple(names)
    if "payload_profiles" in data:
        profiles = data["payload_profiles"]
        if not isinstance(profiles, (list, tuple)) or not profiles or not all(p in PAYLOAD_PROFILES for p in profiles):
            raise _error("payload_profiles", f"expected a non-empty list from {PAYLOAD_PROFILES}, found {profiles!r}")
        kwargs["payload_profiles"] = tuple(profiles)
    if "t_final" in data:
        kwargs["t_final"] = _number("t_final", data["t_final"], "s")
        if not 6.0 < kwargs["t_final"] < math.inf:
            raise _error("t_final", f"expected a finite horizon > 6 s (metrics are taken after 6 s), found "
                         f"{kwargs['t_final']:g}")
    if "rho" in data:
        kwargs["rho"] = _number("rho", data["rho"], "-")
        if not 0 < kwargs["rho"] < math.inf:
            raise _error("rho", f"expected a finite number > 0, found {kwargs['rho']:g}")
    if "eta" in data:
        kwargs["eta"] = _number("eta", data["eta"], "-")
        if not 1 <= kwargs["eta"] < math.inf:
            raise _error("eta", f"expected a finite number >= 1, found {kwargs['eta']:g}")
    for name, low in (("runs", 1), ("seed", 0)):
        if name in data:
            value = data[name]
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise _error(name, f"expected an integer >= {low}, found {value!r}")
            kwargs[name] = value
    ranges = _default_ranges()
    for name in SPEC_FIELDS:
        if name in data:
            ranges[name] = _range(name, data[name])
    return CampaignSpec(ranges=ranges, **kwargs)


def load_spec(path: str | os.PathLike[str]) -> CampaignSpec:
    """Read and validate a campaign TOML file.

    Parameters
    ----------
    path : path-like
        The spec file (see ``examples/campaign.toml``).

    Returns
    -------
    CampaignSpec


    Raises
    ------
    OSError
        If the file cannot be read.
    CampaignSpecError
        If it is not valid TOML or a field is bad (the message names it).
    """
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib

    with open(path, "rb") as fh:
        try:
            data = tomllib.load(fh)
        except tomllib.TOMLDecodeError as err:
            raise CampaignSpecError(f"campaign spec {os.fspath(path)!r} is not valid TOML: {err}") from err
    return spec_from_dict(data)


def draw_scenario(spec: CampaignSpec, seed: int, index: int) -> dict[str, Any]:
    """The inputs of scenario `index`, drawn from ``default_rng([seed, index])``.

    Parameters
    ----------
    spec : CampaignSpec
    seed : int
        Campaign seed (>= 0).
    index : int
        Scenario number (>= 0).


    Returns
    -------
    dict
        ``scenario`` (the index), ``payload_profile`` and one value per
        :data:`SPEC_FIELDS` entry, with ``initial_error`` split into ``e1_0``, ``e2_0``.
    """
    rng = np.random.default_rng([int(seed), int(index)])
    out: dict[str, Any] = {"scenario": int(index)}
    out["payload_profile"] = spec.payload_profiles[int(rng.integers(len(spec.payload_profiles)))]
    for name in SPEC_FIELDS:
        if name == "initial_error":
            out["e1_0"] = spec.ranges[name].draw(rng)
            out["e2_0"] = spec.ranges[name].draw(rng)
        else:
            out[name] = spec.ranges[name].draw(rng)
    return out


def run_draw(spec: CampaignSpec, draw: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Simulate every controller of `spec` on one drawn scenario; one row each.

    A run that raises or diverges gives a row with ``success = False`` and its
    ``error``; metrics that do not exist are NaN.

    Parameters
    ----------
    spec : CampaignSpec
    draw : mapping
        From :func:`draw_scenario`.

    Returns
    -------
    list of dict
        One row per controller: the drawn inputs, ``controller``, ``success``,
        ``diverged``, ``error`` and the metrics of :func:`scara_robust.tracking_metrics`.
    """
    params = replace(spec.robot, cp=draw["cp"])
    peak = draw["payload_peak"]
    if draw["payload_profile"] == "sinusoidal":
        payload: Any = SinusoidalPayload(0.5 * peak, 0.5 * peak, draw["payload_omega"], draw["payload_phase"])
    else:
        payload = ConstantPayload(peak)
    reference = sinusoidal_reference(draw["reference_amplitude"], draw["reference_omega"])
    wave = SquareWave(draw["disturbance_amplitude"], draw["disturbance_period"], draw["disturbance_phase"])
    scenario = Scenario(f"mc-{draw['scenario']}", (draw["e1_0"], draw["e2_0"]), (0.0, 0.0))
    limit = None if math.isinf(draw["torque_limit"]) else draw["torque_limit"]
    rows = []
    for name in spec.controllers:
        row: dict[str, Any] = dict(draw)
        row["controller"] = name
        metrics = dict.fromkeys(METRIC_NAMES, math.nan)
        try:
            options: dict[str, Any] = {"reference": reference, "torque_limit": limit}
            options.update({"rho": spec.rho, "eta": spec.eta} if name == "pid" else {"params": params})
            result = simulate(
                make_controller(name, **options),
                scenario,
                params=params,
                payload=payload,
                reference=reference,
                disturbance=wave,
                t_final=spec.t_final,
                method="fast",
                sample_time=SAMPLE_TIMES.get(name),
            )
            row.update(success=result.success, diverged=result.diverged, error="" if result.success else result.message)
            if result.success:
                metrics = result.metrics().to_dict()
        except Exception as err:  # a failed scenario is data, not a crash
            row.update(success=False, diverged=False, error=f"{type(err).__name__}: {err}")
        row.update(metrics)
        rows.append(row)
    return rows


def _run_chunk(spec: CampaignSpec, seed: int, indices: Sequence[int]) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for i in indices:
        rows.extend(run_draw(spec, draw_scenario(spec, seed, i)))
    return rows


#: Columns of a results table, in order.
_DRAWN = ["payload_profile", *[n for n in SPEC_FIELDS if n != "initial_error"], "e1_0", "e2_0"]
_COLUMNS = ["scenario", "controller", "success", "diverged", "error", *METRIC_NAMES, *_DRAWN, "seed", "spec"]


def read_results(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a campaign results file (``.csv`` or ``.parquet``).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    pandas.DataFrame
        One row per (scenario, controller); ``error`` is a string (empty when none).


    Raises
    ------
    OSError
        If it cannot be read.
    ValueError
        If the extension is not ``.csv`` or ``.parquet`` or the file is not a campaign table.
    """
    fmt = _format(path)
    frame = pd.read_csv(path, keep_default_na=False, na_values=["", "NaN", "nan"]) if fmt == "csv" else (
        pd.read_parquet(path)
    )
    missing = {"scenario", "controller", "success", "seed", "spec"} - set(frame.columns)
    if missing:
        raise ValueError(f"`results` {os.fspath(path)!r} is not a campaign table: missing columns {sorted(missing)}")
    frame["error"] = ["" if isinstance(v, float) and math.isnan(v) else str(v) for v in frame["error"]]
    return frame


def _format(path: str | os.PathLike[str]) -> str:
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in _FORMATS:
        raise ValueError(f"`--output` must end in .csv or .parquet, found {os.fspath(path)!r}")
    if _FORMATS[ext] == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError as err:
            raise ValueError("parquet files need pyarrow: pip install scara_robust[parquet], or use .csv") from err
    return _FORMATS[ext]


def _write(path: str, frame: pd.DataFrame) -> None:
    from .cli import write_atomic

    if _format(path) == "csv":
        write_atomic(path, lambda tmp: frame.to_csv(tmp, index=False))
    else:
        write_atomic(path, lambda tmp: frame.to_parquet(tmp, index=False))


def _normalize(frame: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    frame = frame[columns].sort_values(["scenario", "controller"], kind="stable").reset_index(drop=True)
    return frame.astype({"scenario": int, "seed": int, "success": bool, "diverged": bool, "error": str})


def _chunks(indices: Sequence[int], size: int) -> Iterator[list[int]]:
    for start in range(0, len(indices), size):
        yield list(indices[start : start + size])


def run_campaign(
    spec: CampaignSpec,
    output: str | os.PathLike[str],
    *,
    runs: int | None = None,
    seed: int | None = None,
    workers: int = 1,
    scheduler: str = "local",
    address: str | None = None,
    resume: bool = False,
    chunk_size: int = 4,
    progress: bool = False,
    on_chunk: Callable[[int], None] | None = None,
) -> pd.DataFrame:
    """Run a campaign and store one row per (scenario, controller) in `output`.

    Parameters
    ----------
    spec : CampaignSpec
    output : path
        ``.csv`` or ``.parquet`` file, rewritten atomically after every chunk, sorted by
        scenario and controller.
    runs, seed : int, optional
        Number of scenarios and seed (default: the spec's).
    workers : int
        Processes (local) or workers of the ``LocalCluster`` (dask), >= 1. One local
        worker runs in this process.
    scheduler : {'local', 'dask'}
    address : str, optional
        Address of a running dask scheduler (default: start a ``LocalCluster``).
    resume : bool
        Continue an existing `output` of the same spec and seed, running only the
        scenarios it lacks. Without it, an existing `output` is an error (never
        overwritten).
    chunk_size : int
        Scenarios per task (>= 1).
    progress : bool
        A tqdm bar over scenarios on stderr.
    on_chunk : callable, optional
        Called with the number of scenarios stored after each chunk is written.

    Returns
    -------
    pandas.DataFrame
        The whole table, as stored.
    """
    from tqdm import tqdm

    from ._validation import check_choice, check_int

    if not isinstance(spec, CampaignSpec):
        raise TypeError(f"`spec` must be a CampaignSpec, found {type(spec).__name__}")
    check_choice("scheduler", scheduler, SCHEDULERS)
    runs = spec.runs if runs is None else runs
    seed = spec.seed if seed is None else seed
    checks = (("runs", runs, 1), ("seed", seed, 0), ("workers", workers, 1), ("chunk_size", chunk_size, 1))
    for name, value, low in checks:
        check_int(name, value, low)
    path = os.fspath(output)
    _format(path)
    columns = _COLUMNS
    digest = spec.digest()
    done: set[int] = set()
    stored = pd.DataFrame(columns=columns)
    if os.path.exists(path):
        if not resume:
            raise FileExistsError(f"`--output` {path!r} exists; pass --resume to continue it, or choose another file")
        stored = read_results(path)
        other = stored[(stored["spec"] != digest) | (stored["seed"] != seed)]
        if len(other):
            raise ValueError(f"`--resume`: {path!r} holds rows of another spec or seed; it cannot be continued")
        counts = stored.groupby("scenario")["controller"].nunique()
        done = set(counts[counts == len(spec.controllers)].index.astype(int))
        stored = stored[stored["scenario"].isin(done)]
    todo = [i for i in range(int(runs)) if i not in done]
    bar = tqdm(
        total=int(runs), initial=len(done), disable=not progress, file=sys.stderr, desc="campaign", unit="scenario"
    )

    def store(rows: list[dict[str, Any]]) -> None:
        nonlocal stored
        fresh = pd.DataFrame(rows).assign(seed=int(seed), spec=digest)
        stored = _normalize(pd.concat([stored, fresh], ignore_index=True) if len(stored) else fresh, columns)
        _write(path, stored)
        bar.update(len({r["scenario"] for r in rows}))
        if on_chunk is not None:
            on_chunk(int(stored["scenario"].nunique()))

    try:
        for rows in _execute(spec, int(seed), todo, int(workers), scheduler, address, int(chunk_size)):
            store(rows)
    finally:
        bar.close()
    if not len(stored):
        stored = _normalize(pd.DataFrame(columns=columns), columns)
    return stored


def _execute(
    spec: CampaignSpec, seed: int, todo: list[int], workers: int, scheduler: str, address: str | None, size: int
) -> Iterable[list[dict[str, Any]]]:
    chunks = list(_chunks(todo, size))
    if not chunks:
        return
    if scheduler == "dask":
        yield from _execute_dask(spec, seed, chunks, workers, address)
    elif workers == 1:
        for chunk in chunks:
            yield _run_chunk(spec, seed, chunk)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(_run_chunk, spec, seed, chunk) for chunk in chunks]
            try:
                for future in as_completed(futures):
                    yield future.result()
            finally:
                for future in futures:
                    future.cancel()


def _execute_dask(
    spec: CampaignSpec, seed: int, chunks: list[list[int]], workers: int, address: str | None
) -> Iterable[list[dict[str, Any]]]:
    try:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed
    except ImportError as err:
        raise ValueError("`--scheduler dask` needs the `dask` extra: pip install scara_robust[dask]") from err
    # dask.distributed is not typed: its calls are untyped for mypy
    cluster = (
        None
        if address
        else LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None)  # type: ignore[no-untyped-call]
    )
    client = Client(address if address else cluster)  # type: ignore[no-untyped-call]
    try:
        futures = [client.submit(_run_chunk, spec, seed, chunk, pure=False) for chunk in chunks]
        for future in dask_completed(futures):  # type: ignore[no-untyped-call]
            yield future.result()
    finally:
        client.close()  # type: ignore[no-untyped-call]
        if cluster is not None:
            cluster.close()


def campaign_report(results: pd.DataFrame, quantiles: Sequence[float] = (0.05, 0.5, 0.95)) -> pd.DataFrame:
    """Per-controller statistics of a campaign table.

    Parameters
    ----------
    results : pandas.DataFrame
        From :func:`run_campaign` or :func:`read_results`.
    quantiles : sequence of float
        Quantiles of each metric over the successful runs, in [0, 1].

    Returns
    -------
    pandas.DataFrame
        Index: controller. Columns ``runs``, ``failures``, ``failure_rate`` and, for
        each metric, ``<metric> q<p>`` for every quantile and ``<metric> max``.
    """
    if not isinstance(results, pd.DataFrame) or not {"controller", "success", *METRIC_NAMES} <= set(results.columns):
        raise ValueError("`results` must be a campaign table with controller, success and metric columns")
    qs = [float(q) for q in quantiles]
    if not qs or any(not 0.0 <= q <= 1.0 for q in qs):
        raise ValueError(f"`quantiles` must be numbers in [0, 1], found {list(quantiles)!r}")
    rows = {}
    for name, group in results.groupby("controller", sort=True):
        ok = group[group["success"].astype(bool)]
        row: dict[str, float] = {
            "runs": len(group),
            "failures": int((~group["success"].astype(bool)).sum()),
        }
        row["failure_rate"] = row["failures"] / row["runs"]
        for metric in METRIC_NAMES:
            values = ok[metric].astype(float)
            for q in qs:
                row[f"{metric} q{q * 100:g}"] = float(values.quantile(q)) if len(values) else math.nan
            row[f"{metric} max"] = float(values.max()) if len(values) else math.nan
        rows[name] = row
    return pd.DataFrame.from_dict(rows, orient="index").rename_axis("controller")


def _cmd_campaign(args: argparse.Namespace) -> str:
    from .cli import resolve_setup

    spec = load_spec(args.spec)
    if args.robot is not None:
        spec = replace(spec, robot=resolve_setup(args).params)
    output = args.results or "results.csv"
    try:
        table = run_campaign(
            spec,
            output,
            runs=args.runs,
            seed=args.seed,
            workers=args.workers,
            scheduler=args.scheduler,
            address=args.address,
            resume=args.resume,
            chunk_size=args.chunk_size,
            progress=True,
        )
    except ValueError as err:
        message = str(err)
        for name in ("runs", "seed", "workers"):
            message = message.replace(f"`{name}`", f"`--{name}`")
        raise ValueError(message.replace("`chunk_size`", "`--chunk-size`")) from err
    failures = int((~table["success"].astype(bool)).sum())
    return (
        f"campaign: {table['scenario'].nunique()} scenarios x {len(spec.controllers)} controllers "
        f"= {len(table)} rows in {output} ({failures} failed runs)"
    )


def _cmd_report(args: argparse.Namespace) -> str:
    from .cli import write_atomic

    results = read_results(args.results)
    report = campaign_report(results)
    plot = args.plot or os.path.splitext(args.results)[0] + "-report.png"
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .plotting import plot_campaign

    fig = plot_campaign(results)
    write_atomic(plot, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
    plt.close(fig)
    if args.format == "json":
        return str(report.reset_index().to_json(orient="records", indent=2))
    if args.format == "csv":
        return str(report.to_csv())
    return str(report.T.to_string(float_format="%.4g")) + f"\nfigure: {plot}"


def add_campaign_parsers(sub: Any) -> None:
    """Register ``campaign`` and ``campaign-report`` on the ``python -m scara_robust`` sub-parsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of :func:`scara_robust.cli.main`.
    """
    p = sub.add_parser(
        "campaign",
        help="Monte-Carlo campaign: draw scenarios from a TOML spec, simulate every controller",
        description="Fields of the spec (TOML): controllers, t_final [s], rho, eta, payload_profiles, runs, seed, "
        + ", ".join(f"{n} [{v[0]}]" for n, v in SPEC_FIELDS.items())
        + "; each drawn field is a number or {min = ..., max = ...}. See examples/campaign.toml.",
    )
    p.add_argument("spec", help="campaign spec, TOML")
    p.add_argument("--robot", metavar="FILE", help="robot file (default: the paper's robot); cp is drawn by the spec")
    p.add_argument("--runs", type=int, help="number of scenarios (default: the spec's)")
    p.add_argument("--seed", type=int, help="seed (default: the spec's)")
    p.add_argument("--workers", type=int, default=1, help="processes or dask workers (default 1)")
    p.add_argument("--scheduler", choices=SCHEDULERS, default="local")
    p.add_argument("--address", help="address of a running dask scheduler (with --scheduler dask)")
    # dest is not `output`: the summary line goes to stdout, the table to this file
    p.add_argument("--output", dest="results", help="results file, .csv or .parquet (default results.csv)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted campaign in --output")
    p.add_argument("--chunk-size", type=int, default=4, help="scenarios per task (default 4)")
    p.set_defaults(func=_cmd_campaign)

    p = sub.add_parser("campaign-report", help="per-controller statistics of a campaign, and a figure")
    p.add_argument("results", help="results file of `campaign` (.csv or .parquet)")
    p.add_argument("--format", choices=("text", "csv", "json"), default="text")
    p.add_argument("--plot", metavar="FILE.png", help="figure path (default: RESULTS-report.png)")
    p.add_argument("--output", help="write the statistics to this file instead of stdout")
    p.set_defaults(func=_cmd_report)
