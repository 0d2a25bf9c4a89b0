"""Run functions for campaigns: ``f(spec: dict, rng: numpy.random.Generator) -> dict``.

A run function gets one point's specification (see :mod:`inmotion.evaluate.sweep`) and the run's
own Generator (see :mod:`inmotion.evaluate.campaign`), and returns a dict of scalars (nested dicts
allowed, flattened with ``.``) plus, optionally, ``"arrays": {name: ndarray}`` written to the
run's ``.npz`` file. It must be importable by name (``"module:function"``) on the workers.
A run function may carry a ``validate_spec(spec)`` attribute raising :class:`BadInput`,
called once per point before the campaign starts.

:func:`default_run` is the one of ``inmotion montecarlo``: simulate, perturb the initial state,
run the method, compare with truth. :func:`empty_run`, :func:`synthetic_run` and :func:`burn_run`
measure the engine and test it without the rest of the package.
"""
from __future__ import annotations

import copy
import json
import re
import os
import time

import numpy as np

from ..errors import BadInput

__all__ = ["default_run", "validate_spec", "parse_init_error", "initial_state", "empty_run",
           "synthetic_run", "burn_run"]

#: the attitude errors an init-error spec may give, in DESIGN order
INIT_ANGLES = ("pitch", "roll", "yaw")
_ANGLE_UNITS_RAD = {"deg": np.pi / 180.0, "arcmin": np.pi / 10800.0, "arcsec": np.pi / 648000.0,
                    "rad": 1.0}


# ---------------------------------------------------------------------------- initial state
def parse_init_error(value) -> dict:
    """An initial-attitude error spec as ``{"angles_rad": (3,) [pitch, roll, yaw], "distribution"}``.

    Accepted forms (human units at the edge)::

        "pitch=1deg,roll=1deg,yaw=5deg"                       # fixed offsets (the CLI form)
        {"pitch_deg": 1, "roll_arcmin": 30, "yaw_deg": 5, "distribution": "normal"}

    ``distribution: fixed`` (default) adds the angles as given; ``normal`` draws each angle from
    a zero-mean normal law with the given value as its 1-sigma, anew for every run.
    """
    if value is None or value == {} or value == "":
        return {"angles_rad": np.zeros(3), "distribution": "fixed"}
    if isinstance(value, str):
        value = _parse_init_text(value)
    if not isinstance(value, dict):
        raise BadInput(f"init_error must be a mapping or 'pitch=1deg,...', got {value!r}")
    value = dict(value)
    dist = value.pop("distribution", "fixed")
    if dist not in ("fixed", "normal"):
        raise BadInput(f"init_error distribution must be 'fixed' or 'normal', got {dist!r}")
    angles = np.zeros(3)
    for key, v in value.items():
        name, _, unit = key.partition("_")
        if name not in INIT_ANGLES or unit not in _ANGLE_UNITS_RAD:
            raise BadInput(f"init_error: unknown field {key!r} (expected e.g. pitch_deg, "
                           f"roll_arcmin, yaw_deg)")
        try:
            angles[INIT_ANGLES.index(name)] = float(v) * _ANGLE_UNITS_RAD[unit]
        except (TypeError, ValueError):
            raise BadInput(f"init_error: {key} must be a number, got {v!r}") from None
        if isinstance(v, bool) or not abs(angles[INIT_ANGLES.index(name)]) <= np.pi:
            raise BadInput(f"init_error: {key} = {v!r} is beyond 180 deg (or not a finite "
                           "number)")
    return {"angles_rad": angles, "distribution": dist}


def _parse_init_text(text: str) -> dict:
    out = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        m = re.fullmatch(r"(pitch|roll|yaw)\s*=\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
                         r"\s*(deg|arcmin|arcsec|rad)", item)
        if not m:
            raise BadInput(f"init error {item!r}: expected NAME=VALUEUNIT, e.g. 'yaw=5deg' "
                           f"(NAME pitch/roll/yaw, UNIT deg/arcmin/arcsec/rad)")
        out[f"{m[1]}_{m[3]}"] = float(m[2])
    return out


def initial_state(truth, init_error, rng: np.random.Generator):
    """The method's starting state: truth row 0 with the attitude error of ``init_error``.

    Parameters
    ----------
    truth : inmotion.core.bundle.Truth
    init_error : anything :func:`parse_init_error` takes
    rng : Generator, used only for ``distribution: normal``

    Returns
    -------
    init : NavState
    delta_rad : (3,) the [pitch, roll, yaw] error added [rad]
    """
    from ..core.solution import NavState
    spec = parse_init_error(init_error)
    delta = spec["angles_rad"].copy()
    if spec["distribution"] == "normal":
        delta = rng.normal(0.0, 1.0, 3) * delta
    return NavState.from_truth(truth, euler_error=delta), delta


# ---------------------------------------------------------------------------- the real run
#: the keys of a default_run specification (a sweep's base without its campaign keys)
SPEC_KEYS = ("scenario", "method", "method_options", "init_error", "save_arrays", "description")


def validate_spec(spec: dict) -> None:
    """Check one point of a :func:`default_run` campaign before anything runs."""
    from pydantic import ValidationError
    from .. import registry
    for key in ("scenario", "method"):
        if key not in spec:
            raise BadInput(f"the campaign needs a {key!r} (sweep file or --{key})")
    import difflib
    for key in spec:
        if key not in SPEC_KEYS:
            close = difflib.get_close_matches(str(key), SPEC_KEYS, n=1)
            hint = (f"; did you mean {close[0]!r}?" if close else
                    f"; a grid key is a dotted path into one of {', '.join(SPEC_KEYS)} "
                    "(e.g. scenario.start.speed_m_s)")
            raise BadInput(f"unknown key {key!r} in the run specification{hint}")
    try:
        _, config_cls = registry.get(spec["method"]).load()
    except KeyError as exc:
        raise BadInput(str(exc.args[0])) from None
    from ..config_checks import check_config, check_values
    try:
        check_values(spec.get("method_options") or {})
    except BadInput as exc:
        raise BadInput(f"method_options for {spec['method']!r}: {exc.what}") from None
    try:
        config = config_cls(**(spec.get("method_options") or {}))
    except ValidationError as exc:
        raise BadInput(f"method_options for {spec['method']!r}: {_first_error(exc)}") from None
    except TypeError as exc:
        raise BadInput(f"method_options for {spec['method']!r}: {exc}") from None
    check_config(config, spec["method"])
    parse_init_error(spec.get("init_error"))
    from ..sim.scenario import load_scenario
    try:
        load_scenario(spec["scenario"])
    except ValidationError as exc:
        raise BadInput(f"scenario: {_first_error(exc)}") from None


def _first_error(exc) -> str:
    e = exc.errors()[0]
    return f"{'.'.join(map(str, e.get('loc', ())))}: {e.get('msg', '')}"


def default_run(spec: dict, rng: np.random.Generator) -> dict:
    """Simulate the scenario, run the method from a perturbed truth start, compare with truth.

    The run's Generator is split (``rng.spawn(2)``) into one stream for the simulation and one for
    the initial error, so every point of a sweep sees the same drive for the same run index
    whatever its init-error setting (common random numbers).

    Returns
    -------
    dict
        ``errors.*`` (the ``errors`` block of ``summary.json``, flattened by the engine),
        ``init_error.{pitch,roll,yaw}_arcmin`` (drawn), ``method_s`` (the method's wall time) and,
        with ``save_arrays: true``, the error series as arrays.
    """
    from .. import registry
    from ..core.metrics import error_series, errors_block
    rng_sim, rng_init = rng.spawn(2)
    bundle = simulate_cached(spec["scenario"], rng_sim)
    run, config_cls = registry.get(spec["method"]).load()
    config = config_cls(**(spec.get("method_options") or {}))
    init, delta = initial_state(bundle.truth, spec.get("init_error"), rng_init)
    t0 = time.perf_counter()
    solution = run(bundle, config, init)
    method_s = time.perf_counter() - t0
    from ..io.result import check_solution
    check_solution(solution, hint=" (the method diverged)")   # an error row, never NaN stats
    series = error_series(solution, bundle.truth)
    out = {"errors": errors_block(series), "method_s": method_s,
           "init_error": {f"{n}_arcmin": float(d) * 10800.0 / np.pi
                          for n, d in zip(INIT_ANGLES, delta)}}
    if spec.get("save_arrays"):
        out["arrays"] = {**error_arrays(series, solution), **track_arrays(bundle.truth)}
    return out


def scenario_key(spec: dict) -> str:
    """The scenario of a point as canonical JSON: points with equal keys share their drives."""
    return json.dumps(spec.get("scenario"), sort_keys=True, default=str)


default_run.validate_spec = validate_spec
default_run.affinity = scenario_key

#: the last simulated drive of this process: (scenario key, generator state) -> Bundle
_LAST_DRIVE: dict = {}


def simulate_cached(scenario, rng_sim: np.random.Generator):
    """``simulate(load_scenario(scenario), rng_sim)``, reusing this process's previous drive when
    the scenario and the generator's state are the same (the methods of one run index of a sweep
    get the same drive: common random numbers). A copy is returned, so a method cannot change the
    drive the next one gets; the generator is advanced exactly as a fresh simulation would.
    One drive is kept, so memory does not grow.
    """
    from ..sim import simulate
    from ..sim.scenario import load_scenario
    key = (scenario_key({"scenario": scenario}),
           json.dumps(rng_sim.bit_generator.state, sort_keys=True, default=str))
    if key in _LAST_DRIVE:
        bundle, state_after = _LAST_DRIVE[key]
        rng_sim.bit_generator.state = state_after
        return copy.deepcopy(bundle)
    bundle = simulate(load_scenario(scenario), rng_sim)
    _LAST_DRIVE.clear()
    _LAST_DRIVE[key] = (copy.deepcopy(bundle), rng_sim.bit_generator.state)
    return bundle


#: Solution.sigma name -> (error_series column it bounds, factor from SI to that column's unit)
SIGMA_TO_ERROR = {"phi_E": ("phi_E_arcmin", 10800.0 / np.pi),
                  "phi_N": ("phi_N_arcmin", 10800.0 / np.pi),
                  "phi_U": ("phi_U_arcmin", 10800.0 / np.pi),
                  "vE": ("vE_m_s", 1.0), "vN": ("vN_m_s", 1.0), "vU": ("vU_m_s", 1.0),
                  "north": ("north_m", 1.0), "east": ("east_m", 1.0), "h": ("vertical_m", 1.0)}


def error_arrays(series, solution) -> dict:
    """The error series (``err.<column>``) and the method's 1-sigma in the same units
    (``sigma.<column>``, see :data:`SIGMA_TO_ERROR`) at the series' epochs, for the report's
    3-sigma envelopes."""
    t = series["t"].to_numpy()
    arrays = {"t": t}
    for col in series.columns:
        if col != "t":
            arrays[f"err.{col}"] = series[col].to_numpy(dtype=float)
    keep = (solution.t >= t[0]) & (solution.t <= t[-1])
    for name, sig in solution.sigma.items():
        if name in SIGMA_TO_ERROR and len(sig) == len(solution.t):
            col, scale = SIGMA_TO_ERROR[name]
            arrays[f"sigma.{col}"] = np.asarray(sig, dtype=float)[keep] * scale
    return arrays


def track_arrays(truth, max_points: int = 2000) -> dict:
    """The truth's plan view, ``track.north_m`` / ``track.east_m`` from its first point (local
    radii, :func:`inmotion.core.earth.local_ne_offsets`), thinned to at most ``max_points``."""
    from ..core.earth import local_ne_offsets
    step = max(1, -(-len(truth.t) // max_points))
    north, east = local_ne_offsets(truth.lat[::step], truth.lon[::step], truth.lat[0],
                                   truth.lon[0], truth.h[0])
    return {"track.t": truth.t[::step], "track.north_m": north, "track.east_m": east}


# ---------------------------------------------------------------------------- engine checks
def empty_run(spec: dict, rng: np.random.Generator) -> dict:
    """Does nothing: measures the engine's own cost per run."""
    return {}


def synthetic_run(spec: dict, rng: np.random.Generator) -> dict:
    """A cheap stand-in for a real run, for tests: ``n`` normal draws scaled by ``scale``.

    Spec keys: ``n`` (draws, default 64), ``scale`` (default 1), ``sleep_s`` (wall time to
    spend, default 0), ``fail_value`` (the run raises when its first draw exceeds it),
    ``save_arrays`` (the draws' cumulative sum as ``err.north_m`` with its 1-sigma),
    ``exit_value`` (the run's process exits at once, ``os._exit(70)``, when its first draw
    exceeds it: a stand-in for a crash in native code that takes the worker with it).

    Returns the mean, standard deviation and maximum of the draws (exactly reproducible from the
    Generator), so two executions of one run can be compared bit for bit.
    """
    x = rng.normal(0.0, float(spec.get("scale", 1.0)), int(spec.get("n", 64)))
    if spec.get("sleep_s"):
        time.sleep(float(spec["sleep_s"]))
    if "exit_value" in spec and x[0] > float(spec["exit_value"]):
        os._exit(70)
    if "fail_value" in spec and x[0] > float(spec["fail_value"]):
        raise RuntimeError(f"synthetic failure: first draw {float(x[0]):.6g} > {spec['fail_value']}")
    out = {"mean": float(x.mean()), "std": float(x.std()), "max": float(x.max()),
           "stats": {"first": float(x[0])}}
    if spec.get("save_arrays"):
        # a random walk standing in for a position error, with its exact 1-sigma
        k = np.arange(1, len(x) + 1, dtype=float)
        out["arrays"] = {"t": k - 1.0, "err.north_m": np.cumsum(x),
                         "sigma.north_m": float(spec.get("scale", 1.0)) * np.sqrt(k)}
    return out


def burn_run(spec: dict, rng: np.random.Generator) -> dict:
    """A CPU-bound run of fixed cost (``iterations`` logistic-map steps on a vector), for the
    scaling benchmark: no I/O, no sleeping, one core."""
    x = rng.uniform(0.1, 0.9, int(spec.get("size", 10_000)))
    for _ in range(int(spec.get("iterations", 2000))):
        x = 3.9 * x * (1.0 - x)
    return {"checksum": float(x.sum())}
