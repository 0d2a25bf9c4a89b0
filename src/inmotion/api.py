"""The Python API: the handful of functions ``import inmotion`` gives (``docs/extending.md``).

::

    import inmotion
    b = inmotion.simulate("demo", 1)                      # a shipped scenario, seed 1
    sol = inmotion.run("sins-dr", b, end=120.0)           # a method by name -> Solution
    inmotion.evaluate(sol, b)["final"]["horizontal_m"]    # errors against truth [m]

Every function here imports what it needs when called, so ``import inmotion`` stays cheap (no
numba, scipy or pandas). :func:`run` is the command line's own code path: it starts a method
with the helper behind ``--init`` (:func:`inmotion.cli.main._initial_state`), reads a
configuration file with the one behind ``--config`` (:func:`inmotion.cli.main.build_config`)
and runs the method with :func:`inmotion.cli.main.run_method` (the window, the timing, the
configuration echo), so a method run from Python and one run by ``inmotion navigate`` /
``inmotion align`` are the same call.

Units: SI inside (rad, m, s, m/s), latitude and longitude in rad; configurations carry their
unit in each field name (``gyro_drift_deg_h``), as in the YAML files.
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Optional, Union

from . import registry
from .errors import BadInput

if TYPE_CHECKING:                       # pragma: no cover - typing only
    import numpy as np
    import pandas as pd
    from pydantic import BaseModel

    from .core.bundle import Bundle, Truth
    from .core.solution import NavState, Solution
    from .sim.scenario import Scenario

__all__ = ["simulate", "load_scenario", "scenarios", "methods", "method_config",
           "initial_state", "run", "evaluate", "error_series"]

#: what ``init`` of :func:`run` may be
InitLike = Union[None, str, Path, "NavState", "Solution"]


# --------------------------------------------------------------------------- simulation

def simulate(scenario: Union[str, Path, dict, "Scenario"],
             rng: Union[int, "np.random.Generator", None] = None) -> "Bundle":
    """Simulate one drive: error-free truth and sensor data with their documented errors.

    Parameters
    ----------
    scenario : str, Path, dict or Scenario
        A shipped scenario name (``inmotion.scenarios()``, e.g. ``"demo"``), a YAML file, a
        dict of the YAML's content, or a loaded :class:`~inmotion.sim.scenario.Scenario`.
        Field units are in the field names (``to_speed_m_s``, ``drift_deg_h``).
    rng : int, numpy.random.Generator or None
        The only source of randomness: a seed (int), a generator, or ``None`` for seed 0
        (the command line's default), so the same call gives the same drive.

    Returns
    -------
    Bundle
        SI arrays: ``imu`` (increments [rad], [m/s] over ``(t[k-1], t[k]]``), the velocity
        sensors [m/s] / [m], ``baro`` [m], ``truth`` at the IMU rate (lat, lon [rad], h [m],
        ENU velocity [m/s], Euler ``[pitch, roll, yaw]`` [rad]); ``meta`` as in ``meta.yaml``.

    Raises
    ------
    BadInput
        The scenario is not found or not valid (the file and the first offending field).
    """
    import numpy as np

    from .sim.simulate import simulate as _simulate
    if rng is None:
        rng = 0
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    return _simulate(load_scenario(scenario), rng)


def load_scenario(source: Union[str, Path, dict, "Scenario"]) -> "Scenario":
    """A validated scenario (the pydantic model of the scenario YAML; ``docs/scenarios.md``).

    Parameters
    ----------
    source : str, Path, dict or Scenario
        A YAML file, a shipped scenario name (:func:`scenarios`), a dict of the YAML's content,
        or a Scenario (returned as is). Units are in the field names (``duration_s``,
        ``to_speed_m_s``, ``drift_deg_h``, ``bias_ug``, ``lever_arm_m``).

    Returns
    -------
    Scenario
        Edit a copy with ``scenario.model_dump()`` and pass the dict to :func:`simulate`.

    Raises
    ------
    BadInput
        The file is missing or not valid YAML, or a field is wrong (its name and the file).
    """
    from .sim.scenario import load_scenario as _load
    return _load(source)


def scenarios() -> list[str]:
    """Names of the shipped scenarios (``src/inmotion/scenarios/*.yaml``), for
    :func:`simulate` and :func:`~inmotion.sim.scenario.load_scenario`."""
    from .sim.scenario import shipped_scenarios
    return list(shipped_scenarios())


# --------------------------------------------------------------------------- methods

def methods(kind: Optional[str] = None) -> list[registry.MethodSpec]:
    """The registered methods, in registration order.

    Parameters
    ----------
    kind : ``"align"``, ``"navigate"`` or None (all)

    Returns
    -------
    list of MethodSpec
        Each with ``name`` (what :func:`run` takes), ``kind``, ``needs_attitude`` (False: the
        method finds the attitude itself and uses only the position and velocity of ``init``)
        and a one-line ``summary``.
    """
    if kind not in (None, "align", "navigate"):
        raise ValueError(f"kind must be 'align', 'navigate' or None, got {kind!r}")
    return registry.methods(kind)


def _spec(method: Union[str, registry.MethodSpec]) -> registry.MethodSpec:
    if isinstance(method, registry.MethodSpec):
        return method
    from .cli.main import _spec as cli_spec
    return cli_spec(method)


def method_config(method: Union[str, registry.MethodSpec],
                  config: Union[None, dict, "BaseModel", str, Path] = None,
                  **fields) -> "BaseModel":
    """A method's validated configuration (a pydantic model).

    Parameters
    ----------
    method : a name of :func:`methods`
    config : None (the defaults), a dict, the method's configuration object, or a YAML / JSON
        file, with the units in the field names (``gyro_drift_deg_h``, ``filter_rate_hz``)
    **fields : fields set on top (``mode="velocity-position"``)

    Returns
    -------
    pydantic.BaseModel
        The method's configuration class; ``.model_dump()`` lists every field and its value.

    Raises
    ------
    BadInput
        An unknown field or a value out of range (the first three problems).
    """
    import pydantic
    spec = _spec(method)
    _, Config = spec.load()
    if isinstance(config, (str, Path)):
        from .cli.main import build_config          # what --config FILE does
        cfg = build_config(spec, config)
        if not fields:
            return cfg
        data = cfg.model_dump()
    elif config is None:
        data = {}
    elif isinstance(config, Config):
        data = config.model_dump()
    elif isinstance(config, dict):
        data = dict(config)
    else:
        raise TypeError(f"config must be None, a dict, a {Config.__name__} or a file, got "
                        f"{type(config).__name__}")
    data.update(fields)
    try:
        return Config.model_validate(data)
    except pydantic.ValidationError as e:
        errs = "; ".join(f"{'.'.join(map(str, er['loc'])) or 'config'}: {er['msg']}"
                         for er in e.errors()[:3])
        raise BadInput(f"configuration of {spec.name!r}: {errs}",
                       file=config if isinstance(config, (str, Path)) else None) from None


def initial_state(bundle: "Bundle", init: InitLike = None, start: Optional[float] = None,
                  needs_attitude: bool = True) -> tuple["NavState", str]:
    """Where a method starts: ``(NavState, description)``; the command line's ``--init``.

    Parameters
    ----------
    bundle : Bundle
    init : None, ``"truth"``, ``"meta"``, a NavState, a Solution or a result folder
        ``None``: ``"truth"`` if the bundle has truth, else ``"meta"``. ``"truth"``: the truth
        row at or after ``start`` (the first row without it). ``"meta"``: ``meta.yaml``'s
        ``initial_position`` / ``initial_attitude`` / ``initial_velocity`` at ``start``.
        A Solution or a result folder: its state at ``start``, or where it ended.
    start : float, optional
        Window start [s].
    needs_attitude : bool
        False for methods that find the attitude themselves (``"meta"`` then needs no
        attitude).

    Raises
    ------
    BadInput
        What is missing (no truth table, no initial position, ``start`` outside a result).
    """
    from .core.solution import NavState, Solution
    if init is None:
        init = "truth" if bundle.truth is not None else "meta"
    if isinstance(init, NavState):
        return init, "state"
    if not isinstance(init, Solution):
        from .cli.main import _initial_state          # --init truth | meta | RESULT
        return _initial_state(None, bundle, str(init), start, needs_attitude)
    if start is None:
        return init.final_state(), "solution"
    if start < init.t[0] or start > init.t[-1]:
        raise BadInput(f"start {start:g} s is outside the solution's time span "
                       f"({init.t[0]:.6g} .. {init.t[-1]:.6g} s)")
    return init.state_at(start), "solution"


def run(method: str, bundle: "Bundle", config: Union[None, dict, "BaseModel", str, Path] = None,
        init: InitLike = None, *, start: Optional[float] = None,
        end: Optional[float] = None) -> "Solution":
    """Run a method by name, as ``inmotion navigate`` / ``inmotion align`` does.

    Parameters
    ----------
    method : str
        A name of :func:`methods` (``"sins"``, ``"dr"``, ``"sins-dr"``, ``"dr-kf"``,
        ``"mimada-dual"``, ...).
    bundle : Bundle
        From :func:`simulate` or :func:`~inmotion.io.bundle.read_bundle` (SI inside).
    config : None, dict, the method's configuration object, or a YAML file
        Fields with their unit in the name (``{"filter_rate_hz": 10}``); None: defaults.
        See :func:`method_config`.
    init : None, ``"truth"``, ``"meta"``, NavState, Solution or a result folder
        Where to start (:func:`initial_state`); None: the truth row at ``start`` if the
        bundle has truth, else ``meta.yaml``. A Solution or result starts where it ended
        (or at ``start``), and then ``start`` defaults to that time.
    start, end : float, optional
        Time window [s] of the bundle to run on.

    Returns
    -------
    Solution
        ``t`` [s], ``lat``, ``lon`` [rad], ``h`` [m], ``vel_n`` [m/s] ENU, ``euler`` [rad]
        (``[pitch, roll, yaw]``), ``sigma`` and ``states`` where the method estimates them,
        ``info`` (method, configuration echo, timing).

    Raises
    ------
    BadInput
        Unknown method, invalid configuration, a start the bundle cannot give, a sensor the
        method needs and the bundle lacks.
    """
    import click

    from .cli import main as cli
    spec = _spec(method)
    cfg = method_config(spec, config)
    state, desc = initial_state(bundle, init, start, spec.needs_attitude)
    if start is None and (desc == "solution" or desc.startswith("result")):
        start = state.t                  # continue from where a result ended, as the CLI does
    with click.Context(cli.cli, obj=cli._Opts(quiet=True)) as ctx:
        sol, _ = cli.run_method(ctx, bundle, spec, cfg, state, (start, end))
    return sol


# --------------------------------------------------------------------------- evaluation

def _truth_of(truth):
    from .core.bundle import Bundle
    if isinstance(truth, Bundle):
        if truth.truth is None:
            raise BadInput("the bundle has no truth table")
        return truth.truth
    return truth


def error_series(solution: "Solution", truth: Union["Bundle", "Truth"]) -> "pd.DataFrame":
    """Errors of ``solution`` against truth at every solution epoch, estimate minus truth.

    Parameters
    ----------
    solution : Solution
    truth : Bundle (its truth table) or Truth

    Returns
    -------
    pandas.DataFrame
        ``t`` [s]; ``pitch_arcmin, roll_arcmin, yaw_arcmin`` (Euler differences) and
        ``phi_E_arcmin, phi_N_arcmin, phi_U_arcmin`` (misalignment) [arc-minutes];
        ``vE_m_s, vN_m_s, vU_m_s`` [m/s]; ``north_m, east_m, horizontal_m, vertical_m`` [m];
        ``distance_m`` (truth distance travelled) [m]
        (:func:`inmotion.core.metrics.error_series`).
    """
    from .core.metrics import error_series as _series
    return _series(solution, _truth_of(truth))


def evaluate(solution: "Solution", truth: Union["Bundle", "Truth"],
             window_s: float = 100.0) -> dict:
    """The ``errors`` block of ``summary.json``: how far ``solution`` is from truth.

    Parameters
    ----------
    solution : Solution
    truth : Bundle (its truth table) or Truth
    window_s : float
        Length [s] of the closing window of the ``rms`` and ``max_abs`` statistics.

    Returns
    -------
    dict
        ``final``, ``rms_last_100s``, ``max_abs_last_100s``, each over the keys
        ``pitch_arcmin, roll_arcmin, yaw_arcmin, phi_E_arcmin, phi_N_arcmin, phi_U_arcmin``
        [arc-minutes], ``vE_m_s, vN_m_s, vU_m_s`` [m/s], ``horizontal_m, vertical_m`` [m];
        ``distance_m`` [m] travelled and ``duration_s`` [s]. The per-epoch series is
        :func:`error_series`.
    """
    from .core.metrics import errors_block
    return errors_block(error_series(solution, truth), window_s)
