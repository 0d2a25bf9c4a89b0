"""What the per-paper reproductions (``paper000`` .. ``paper004``, ``real``) share.

A reproduction's Monte Carlo is a **campaign specification**: a sweep file shipped with the
package (``inmotion/reproductions/campaigns/<name>.yaml``, the format of
:mod:`inmotion.evaluate.sweep`: ``name``, ``runs`` (the issue's count), ``seed``, ``run``
(``"module:function"`` of ``f(spec, rng) -> dict`` in the paper's module), the base
specification and a ``grid`` over what the experiment varies, and the paper's figures under
``paper:``). :func:`run_campaign_file` runs it on the project's one campaign engine
(:func:`inmotion.evaluate.montecarlo.run_campaign`) into ``DIR/campaign/<name>/``: each
finished run is on disk at once, a crashed or interrupted reproduction resumes where it
stopped (the same command again), and ``--workers`` / ``--scheduler`` serve it as they serve
``inmotion montecarlo``. The same file runs with the ordinary command
(``inmotion montecarlo $(python -c ...)/paper002.yaml -o DIR``), giving the same table.

The report is then built from the campaign's results table
(:func:`inmotion.evaluate.montecarlo.read_results`) and the runs' arrays. A run function whose
record is nested (lists of dicts, arrays deep inside) returns it through :func:`pack_record`
(the record as JSON text in one column, its arrays in the run's ``.npz``) and the report reads
it back with :func:`unpack_record`, value for value. Besides the engine's ``elapsed_s`` and
``worker``, the only values of a record that differ between two executions of a run are the
timings a paper measures itself (its filters' ``wall_s``, paper 000's ``cpu_s``).

``inmotion reproduce ... --scheduler ADDRESS`` (:func:`engine`) opens the client once for every
paper of the command; without it each campaign opens a local cluster of ``--workers``
single-threaded processes.
"""
from __future__ import annotations

import contextlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

__all__ = ["engine", "drift_free_dr_gyro",
           "conditions_markdown", "turned_heading", "CAMPAIGNS_DIR", "campaign_file",
           "campaign_paper", "run_campaign_file", "CampaignResult", "pack_record",
           "unpack_record", "run_key"]

#: the client opened by :func:`engine` (None: each campaign opens its own)
_CLIENT = None
#: the reproductions' sweep files
CAMPAIGNS_DIR = Path(__file__).with_name("campaigns")


@contextlib.contextmanager
def engine(workers: Optional[int] = None, scheduler: Optional[str] = None):
    """Run every campaign inside the block on one Dask client:
    connected to ``scheduler`` (an address such as ``tcp://host:8786``), or a local cluster of
    ``workers`` processes when ``workers > 1``; with neither, each campaign opens its own."""
    global _CLIENT
    if not scheduler and not (workers and workers > 1):
        yield None
        return
    from ..evaluate.montecarlo import open_client
    with open_client(workers, scheduler) as client:
        old, _CLIENT = _CLIENT, client
        try:
            yield client
        finally:
            _CLIENT = old


# ------------------------------------------------------------------------------ campaigns
def campaign_file(name: str) -> Path:
    """The shipped sweep file ``campaigns/<name>.yaml``."""
    from ..errors import BadInput
    path = CAMPAIGNS_DIR / f"{name}.yaml"
    if not path.is_file():
        have = sorted(p.stem for p in CAMPAIGNS_DIR.glob("*.yaml"))
        raise BadInput(f"no reproduction campaign {name!r} (shipped: {', '.join(have)})")
    return path


def campaign_paper(name: str):
    """The ``paper:`` block of the shipped sweep ``name`` (the paper's figures, written once,
    in the campaign file)."""
    import yaml
    return yaml.safe_load(campaign_file(name).read_text()).get("paper")


@dataclass
class CampaignResult:
    """A finished campaign: its sweep, directory, results table (runs ``< sweep.runs`` of
    every point, sorted by point and run) and the wall time of this call [s]."""

    sweep: object
    directory: Path
    table: object
    wall_s: float
    _store: object = field(default=None, repr=False)

    @property
    def run_s(self) -> float:
        """The runs' own wall times summed [s] (``elapsed_s`` of each record): what the
        campaign cost in worker time, also when this call only resumed it."""
        return float(self.table["elapsed_s"].sum())

    def arrays(self, point_id: int, run_index: int) -> dict:
        """The arrays run ``run_index`` of point ``point_id`` returned (``{}`` if none)."""
        if self._store is None:
            from ..evaluate.store import ResultStore
            self._store = ResultStore(self.directory)
        return self._store.read_arrays(int(point_id), int(run_index)) or {}

    def rows(self, point_id: Optional[int] = None) -> list:
        """The table's rows as dicts (of one point, or all), in (point, run) order; the
        columns of other points (absent in these rows) are left out."""
        df = self.table if point_id is None else self.table[self.table["point_id"] == point_id]
        out = []
        for pid, part in df.groupby("point_id", sort=True):
            part = part.dropna(axis=1, how="all")       # columns only other points have
            out += part.to_dict("records")
        return out

    def records(self, point_id: Optional[int] = None) -> list:
        """The runs' records as :func:`pack_record` stored them, one per row of
        :meth:`rows`, in the same order."""
        return [unpack_record(r["record"], self.arrays(r["point_id"], r["run_index"]))
                for r in self.rows(point_id)]


def run_campaign_file(name: str, out_dir, *, runs: Optional[int] = None,
                      seed: Optional[int] = None, workers: Optional[int] = None,
                      progress: bool = True, overrides: Optional[dict] = None) -> CampaignResult:
    """Run the shipped sweep ``name`` (:func:`campaign_file`) into
    ``out_dir/campaign/<sweep name>/`` on the campaign engine; resumes what is there.

    Parameters
    ----------
    runs, seed : override the file's ``runs`` and ``seed`` (None: the file's)
    workers : local worker processes when no :func:`engine` is open (default 1)
    progress : the engine's progress bar
    overrides : other top-level keys of the file to replace (e.g. ``{"windows": 1}``)

    Returns
    -------
    CampaignResult
        Raises ``RuntimeError`` naming the first failed run (with its traceback) if any run
        failed; calling again re-runs only the failed and missing runs.
    """
    from ..evaluate.montecarlo import run_campaign
    from ..evaluate.sweep import load_sweep
    sweep = load_sweep(campaign_file(name), overrides={**(overrides or {}), "runs": runs, "seed": seed})
    directory = Path(out_dir) / "campaign" / sweep.name
    t0 = time.perf_counter()
    df = run_campaign(sweep, directory, workers=max(1, int(workers or 1)), client=_CLIENT,
                      resume=True, retry_failed=True, quiet=not progress)
    wall = time.perf_counter() - t0
    df = df[df["run_index"] < sweep.runs].reset_index(drop=True)
    bad = df[df["status"] != "ok"]
    if len(bad):
        r = bad.iloc[0]
        raise RuntimeError(f"{len(bad)} run(s) of campaign {sweep.name} failed; run "
                           f"{r['run_index']} of point {r['point_id']} ({r['label']}): "
                           f"{r['error']}\n{r['traceback']}")
    return CampaignResult(sweep, directory, df, wall)


def run_key(rng) -> tuple:
    """``(campaign seed, run index)`` of a campaign run's Generator (its ``SeedSequence`` is
    ``SeedSequence(seed, spawn_key=(k,))``, :func:`inmotion.evaluate.campaign.run_seed_sequence`).

    Papers 000 and 002 draw from their own streams of ``(seed, k)`` (``default_rng([seed,
    k])``-like, as their committed snapshots were drawn); with this they keep them under the
    engine, so a campaign run gives exactly the figures of the former task loop."""
    ss = rng.bit_generator.seed_seq
    return int(ss.entropy), int(ss.spawn_key[-1])


_ARRAY = "__array__"


def pack_record(record: dict) -> dict:
    """A nested run record as a run function's result: ``{"record": JSON text, "arrays":
    {"a0": ndarray, ...}}``. Every numpy array anywhere in ``record`` (in dicts, lists,
    tuples) goes to the run's ``.npz`` and is replaced in the text by ``{"__array__": "aN"}``;
    tuples become lists, numpy scalars Python numbers. :func:`unpack_record` inverts it."""
    arrays = {}

    def walk(x):
        if isinstance(x, np.ndarray):
            key = f"a{len(arrays)}"
            arrays[key] = x
            return {_ARRAY: key}
        if isinstance(x, dict):
            return {str(k): walk(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [walk(v) for v in x]
        if isinstance(x, np.generic):
            return x.item()
        return x
    text = json.dumps(walk(record), allow_nan=True)
    return {"record": text, "arrays": arrays} if arrays else {"record": text}


def unpack_record(text: str, arrays: dict) -> dict:
    """The record :func:`pack_record` stored, arrays back in their places (floats exact:
    JSON keeps the shortest repr that reads back to the same double)."""
    def walk(x):
        if isinstance(x, dict):
            if set(x) == {_ARRAY}:
                return arrays[x[_ARRAY]]
            return {k: walk(v) for k, v in x.items()}
        if isinstance(x, list):
            return [walk(v) for v in x]
        return x
    return walk(json.loads(text))


# ------------------------------------------------------------------------------ task lists
def turned_heading(C_nb, d_yaw_rad):
    """``C_b^n`` with its heading (ENU Euler yaw) changed by ``d_yaw_rad``, pitch and roll kept:
    a start or a first-level answer made a chosen amount worse (paper 003's 53' coarse start,
    paper 004's first level)."""
    import numpy as np

    from ..core import rotations
    e = rotations.euler_from_dcm(np.asarray(C_nb, dtype=float))
    e[2] += d_yaw_rad
    return rotations.dcm_from_euler(e)


def drift_free_dr_gyro(imu, eps_b):
    """The gyro rows of a dead reckoner that does not see the IMU's drift ``eps_b`` (3,)
    [rad/s], a simulation study's oracle (it needs the truth): ``dtheta - eps_b * dt`` per IMU
    row, the first row's interval taken equal to the second's. Passed as ``dtheta_dr`` to
    ``run_dr_kf`` / ``run_sins_dr`` with ``dr_sees_gyro_drift=False``, it is the world paper
    000's printed F describes."""
    import numpy as np
    t = np.asarray(imu.t, dtype=float)
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]) if len(t) > 1 else t[0])
    return imu.dtheta - np.asarray(eps_b, dtype=float)[None, :] * dt[:, None]


def conditions_markdown(rows) -> list:
    """A report's conditions table (issue 17: it opens every report) as markdown lines:
    ``rows`` of ``(parameter, paper's value, ours, why ours differs)``; a ``|`` or a line
    break inside a cell becomes ``/`` or a space."""
    def cell(x):
        return str(x).replace("|", "/").replace("\n", " ")
    L = ["## Conditions", "", "| parameter | paper | ours | why ours differs |",
         "| --- | --- | --- | --- |"]
    L += ["| " + " | ".join(cell(x) for x in row) + " |" for row in rows]
    return L + [""]
