"""A campaign's parameter points: a base specification and a grid, expanded as a cartesian product.

A sweep file (YAML) reads::

    name: gyro-drift-x-speed-x-method
    runs: 50                      # Monte Carlo runs per point
    seed: 2026                    # campaign seed (see inmotion.evaluate.campaign.run_seed_sequence)
    run: inmotion.evaluate.runs:default_run     # the run function (module:function), optional
    scenario: paper004_traj1      # a shipped scenario name, a path (relative to this file) or a mapping
    method: imada-dual
    method_options: {}            # fields of the method's configuration class
    init_error: {pitch_deg: 0.5, roll_deg: 0.5, yaw_deg: 5, distribution: normal}
    grid:                         # dotted paths into the specification -> list of values
      scenario.imu.gyro_bias_deg_h: [0.01, 0.1]
      scenario.speed_m_s: [20, 60, 80]
      method: [imada-vb, imada-dual]
    paper: {...}                  # optional: the paper's figures, for the report

Everything except ``name, runs, seed, run, grid, paper`` is the *base specification* handed to
the run function (a plain dict). Each grid key is a dotted path into that specification; missing
intermediate mappings are created (the run function validates the result, e.g. the scenario's
pydantic schema rejects an unknown field). Points are the cartesian product of the grid values
in the order the keys are written, the last key varying fastest; ``point_id`` is the position in
that order, so adding runs to a campaign never renumbers its points.

A file with none of the keys ``grid, scenario, run, runs, seed, method, paper`` is taken to be a
plain scenario: one point whose specification is ``{"scenario": <the file>}``
(``inmotion montecarlo SCENARIO.yaml --method NAME``).
"""
from __future__ import annotations

import copy
import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional


from ..errors import BadInput

__all__ = ["Point", "Sweep", "load_sweep", "expand_grid", "set_path", "point_label"]

#: keys of a sweep file that describe the campaign rather than a run
CAMPAIGN_KEYS = ("name", "runs", "seed", "run", "grid", "paper")
DEFAULT_RUN = "inmotion.evaluate.runs:default_run"
#: most points a grid may expand to, and most runs a campaign may hold
MAX_POINTS = 10_000
MAX_RUNS = 10_000_000
#: a file with none of these keys is a plain scenario
SWEEP_MARKERS = {"grid", "scenario", "run", "runs", "seed", "method", "paper"}


@dataclass(frozen=True)
class Point:
    """One parameter point: ``params`` are its grid values (dotted path -> value), ``spec`` the
    full specification the run function receives."""

    point_id: int
    params: dict
    spec: dict

    @property
    def label(self) -> str:
        return point_label(self.params)


@dataclass
class Sweep:
    """A campaign description: what to run (``run`` = "module:function"), how often, seeded how."""

    name: str
    points: list
    runs: int = 1
    seed: int = 0
    run: str = DEFAULT_RUN
    paper: Optional[dict] = None
    source: Optional[str] = None
    base: dict = field(default_factory=dict)
    grid: dict = field(default_factory=dict)

    def manifest(self) -> dict:
        """The JSON-able description written to ``campaign.json`` (resume compares it)."""
        return {"name": self.name, "runs": self.runs, "seed": self.seed, "run": self.run,
                "source": self.source, "grid": self.grid, "paper": self.paper,
                "points": [{"point_id": p.point_id, "label": p.label, "params": p.params,
                            "spec": p.spec} for p in self.points]}


def point_label(params: dict) -> str:
    """``"method=a, speed_m_s=20"``: the last component of each dotted path and its value."""
    if not params:
        return "base"
    return ", ".join(f"{k.rsplit('.', 1)[-1]}={_short(v)}" for k, v in params.items())


def _short(v):
    return json.dumps(v) if isinstance(v, (dict, list)) else str(v)


def set_path(spec: dict, path: str, value: Any) -> None:
    """Set ``spec[a][b][c] = value`` for ``path = "a.b.c"``, creating missing mappings.

    Raises
    ------
    BadInput
        If a component on the way exists and is not a mapping.
    """
    keys = path.split(".")
    node = spec
    for i, k in enumerate(keys[:-1]):
        node = node.setdefault(k, {})
        if not isinstance(node, dict):
            raise BadInput(f"grid key {path!r}: {'.'.join(keys[:i + 1])!r} is not a mapping "
                           f"(it is {node!r})")
    node[keys[-1]] = copy.deepcopy(value)


def expand_grid(base: dict, grid: dict) -> list:
    """All points of ``grid`` applied to ``base``, cartesian product, last key fastest.

    Parameters
    ----------
    base : dict
        The base specification (not modified).
    grid : dict
        Dotted path -> non-empty list of values.
    """
    for key, values in grid.items():
        if not isinstance(key, str) or not all(key.split(".")):
            raise BadInput(f"grid key {key!r}: expected a dotted path such as "
                           "scenario.start.speed_m_s")
        if not isinstance(values, list) or not values:
            raise BadInput(f"grid key {key!r}: expected a non-empty list of values, "
                           f"got {_short_repr(values)}")
    n = 1
    for values in grid.values():
        n *= len(values)
    if n > MAX_POINTS:
        sizes = " x ".join(str(len(v)) for v in grid.values())
        raise BadInput(f"the grid has {sizes} = {n:.3g} points; at most {MAX_POINTS} (each "
                       "point is listed in campaign.json; split the sweep)")
    keys = list(grid)
    points = []
    for pid, combo in enumerate(itertools.product(*(grid[k] for k in keys))):
        spec = copy.deepcopy(base)
        for k, v in zip(keys, combo):
            set_path(spec, k, v)
        points.append(Point(pid, dict(zip(keys, combo)), spec))
    return points


def _short_repr(v, n=60) -> str:
    r = repr(v)
    return r if len(r) <= n else r[:n] + "..."


def _check_int(doc, key, default, minimum, file, maximum=None):
    value = doc.get(key, default)
    if isinstance(value, float) and value.is_integer() and key == "runs":
        value = int(value)                      # YAML reads 1e6 as a float
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise BadInput(f"{key!r} must be an integer >= {minimum}, got {_short_repr(value)}",
                       file=file)
    if maximum is not None and value > maximum:
        raise BadInput(f"{key!r} = {value:.3g} is more than the {maximum:.3g} a campaign may "
                       "hold; split it", file=file)
    return value


def _resolve_scenario(scenario, base_dir: Optional[Path], file):
    """A scenario given as a mapping stays; a path or a shipped name becomes its mapping."""
    if scenario is None or isinstance(scenario, dict):
        return scenario
    if not isinstance(scenario, str):
        raise BadInput(f"'scenario' must be a name, a path or a mapping, got {scenario!r}", file=file)
    path = Path(scenario)
    if base_dir is not None and not path.is_absolute():
        path = base_dir / path
    if not path.exists():
        try:
            from ..sim.scenario import find_scenario
            path = Path(find_scenario(scenario))
        except (ImportError, KeyError, FileNotFoundError, BadInput) as exc:
            raise BadInput(f"scenario {scenario!r} is neither a file nor a shipped scenario "
                           f"({exc})", file=file) from None
    return _read_yaml(path)


def _read_yaml(path: Path) -> dict:
    from ..io.safe_yaml import load_yaml_file
    doc = load_yaml_file(path, "YAML", invalid="not valid YAML")
    if not isinstance(doc, dict):
        raise BadInput("expected a mapping at the top level", file=path)
    return doc


def load_sweep(source, *, overrides: Optional[dict] = None) -> Sweep:
    """Read a sweep (or a plain scenario) from a YAML path or a mapping.

    Parameters
    ----------
    source : str, Path or dict
    overrides : dict, optional
        Top-level keys set before expansion, from the command line: ``runs``, ``seed``, ``run``,
        ``method``, ``method_options``, ``init_error`` (``None`` values are ignored).

    Returns
    -------
    Sweep
    """
    file = None
    if isinstance(source, dict):
        doc, base_dir = copy.deepcopy(source), None
    else:
        file = Path(source)
        doc, base_dir = _read_yaml(file), file.resolve().parent
    if not SWEEP_MARKERS & set(doc):
        doc = {"scenario": doc, "name": Path(file).stem if file else "campaign"}
    for k, v in (overrides or {}).items():
        if v is not None:
            doc[k] = v
    grid = doc.get("grid") or {}
    if not isinstance(grid, dict):
        raise BadInput(f"'grid' must be a mapping of dotted paths to lists, got {grid!r}", file=file)
    run = doc.get("run", DEFAULT_RUN)
    if not isinstance(run, str) or ":" not in run:
        raise BadInput(f"'run' must be 'module:function', got {run!r}", file=file)
    base = {k: v for k, v in doc.items() if k not in CAMPAIGN_KEYS}
    base["scenario"] = _resolve_scenario(base.get("scenario"), base_dir, file)
    if base["scenario"] is None:
        base.pop("scenario")
    runs = _check_int(doc, "runs", 1, 1, file, MAX_RUNS)      # before a large grid expands
    seed = _check_int(doc, "seed", 0, 0, file, 2**63 - 1)
    try:
        points = expand_grid(base, grid)
    except BadInput as exc:
        raise BadInput(exc.what, file=file) from None
    return Sweep(name=str(doc.get("name", Path(file).stem if file else "campaign")),
                 points=points, runs=runs, seed=seed, run=run, paper=doc.get("paper"),
                 source=str(file) if file else None, base=base, grid=grid)
