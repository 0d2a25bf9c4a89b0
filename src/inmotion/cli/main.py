"""The ``inmotion`` command line (``docs/cli.md``).

::

    inmotion simulate SCENARIO.yaml|NAME -o BUNDLE [--seed N] [--format csv|parquet]
    inmotion info BUNDLE
    inmotion process  BUNDLE -o RESULT [--config FILE] [--init truth|meta|RESULT]
    inmotion align    BUNDLE --method NAME [--config FILE] -o RESULT [options]
    inmotion navigate BUNDLE --method NAME [--config FILE] -o RESULT [options]
    inmotion evaluate RESULT --truth BUNDLE [--json]
    inmotion methods [NAME]
    inmotion scenarios
    inmotion demo

``align`` / ``navigate`` options: ``--init truth|meta|RESULT`` (default: truth if the bundle
has it, else meta), ``--init-error 'pitch=1deg,roll=1deg,yaw=30arcmin,vE=0.1m/s,north=5m'``
(angles in deg, arcmin, arcsec, rad or mrad; velocities in m/s; positions north/east/up in m),
``--start`` / ``--end`` [s], ``--mode M`` (sets the configuration field ``mode``) and
``--set key=value`` (any configuration field; the value is read as YAML, so ``--set
out_stride=10`` gives an int and ``--set mounting_arcmin=[3,0,-4]`` a list),
``--format csv|parquet`` (result tables), ``--output-rate HZ|all`` (rows per second written;
navigate: 1 Hz by default unless the method's own ``out_stride`` / ``output_rate_hz`` is
set, align: every row the method outputs), ``--allow-imu-gaps`` (integrate across IMU gaps; by
default a bundle with one is refused,
see :mod:`inmotion.io.bundle`). ``info`` always reads IMU gaps and lists them.

Global options ``--quiet``/``-q`` (no progress, no notes), ``--json`` (print the command's
summary as JSON on stdout), ``--debug`` (tracebacks on internal failures). Exit status 0 on
success, 2 on bad input (one line ``inmotion: error: ...`` on stderr), 1 on an internal
failure. The global options are accepted anywhere on the line (:func:`hoist_global_options`).

The CLI is the only place that reads files and prints; methods get a :class:`Bundle`, a
configuration object and a :class:`NavState`.
"""
from __future__ import annotations

import contextlib
import errno
import json
import math
import re
import sys
import tempfile
import time
import traceback
import warnings
from pathlib import Path

import click

from .. import registry
from ..errors import BadInput

__all__ = ["cli", "main", "parse_init_error"]


# --------------------------------------------------------------------------- plumbing

class _Cli(click.Group):
    """A group that maps exceptions to exit statuses: BadInput -> 2, anything else -> 1."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        args = hoist_global_options(list(args) if args is not None else sys.argv[1:])
        try:
            rv = super().main(args=args, prog_name=prog_name or "inmotion",
                              complete_var=complete_var, standalone_mode=False, **extra)
        except BadInput as e:
            click.echo(f"inmotion: error: {e}", err=True)
            sys.exit(2)
        except click.exceptions.Exit as e:
            sys.exit(e.exit_code)
        except click.ClickException as e:     # usage errors: one line too, naming the option
            msg = " ".join(e.format_message().split())
            cmd = getattr(getattr(e, "ctx", None), "command_path", None)
            hint = f" (see '{cmd} --help')" if cmd and isinstance(e, click.UsageError) else ""
            click.echo(f"inmotion: error: {msg}{hint}", err=True)
            sys.exit(2)                        # all of click's are about the user's input
        except click.exceptions.Abort:
            click.echo("inmotion: aborted", err=True)
            sys.exit(130)
        except KeyboardInterrupt:
            click.echo("inmotion: interrupted", err=True)
            sys.exit(130)
        except OSError as e:                  # a path the user gave that cannot be written
            if e.errno not in _PATH_ERRNOS:
                _internal(e, args)
            from ..io.safe_write import output_error
            click.echo(f"inmotion: error: {output_error(e.filename or '?', e, 'cannot use')}",
                       err=True)
            sys.exit(2)
        except MemoryError:
            click.echo("inmotion: error: out of memory (the input asks for more than this "
                       "machine has; shorten it)", err=True)
            sys.exit(2)
        except Exception as e:  # an internal failure: say so, in one line unless --debug
            _internal(e, args)
        sys.exit(rv if isinstance(rv, int) else 0)


#: errors of a path the user gave (no such folder, a file in the way, no permission ...)
_PATH_ERRNOS = {errno.ENOTDIR, errno.ENAMETOOLONG, errno.EACCES, errno.EPERM, errno.EROFS,
                errno.ENOSPC, errno.EDQUOT, errno.EISDIR, errno.ELOOP, errno.EEXIST,
                errno.ENOENT}


def _internal(e, args):
    if "--debug" in (args if args is not None else sys.argv[1:]):
        traceback.print_exc()
    msg = " ".join(f"{type(e).__name__}: {e}".split())
    click.echo(f"inmotion: internal error: {msg} (rerun with --debug for the traceback)",
               err=True)
    sys.exit(1)


#: options of the group that a user may type anywhere on the line
GLOBAL_FLAGS = ("-q", "--quiet", "--json", "--debug")


def hoist_global_options(args: list[str]) -> list[str]:
    """``args`` with the global flags moved in front of the subcommand.

    ``inmotion navigate B -m sins -o R -q`` then means ``inmotion -q navigate B ...``; a
    subcommand's own ``--json`` / ``--quiet`` mean the same as the global ones. Nothing after
    ``--`` moves.
    """
    if "--" in args:
        i = args.index("--")
        head, tail = args[:i], args[i:]
    else:
        head, tail = args, []
    flags = [a for a in head if a in GLOBAL_FLAGS]
    rest = [a for a in head if a not in GLOBAL_FLAGS]
    return list(dict.fromkeys(flags)) + rest + tail


class _Opts:
    def __init__(self, quiet=False, as_json=False, debug=False):
        self.quiet, self.json, self.debug = quiet, as_json, debug


def _opts(ctx) -> _Opts:
    return ctx.find_root().obj or _Opts()


def _json_option(f):
    return click.option("--json", "as_json", is_flag=True,
                        help="Print the summary as JSON on stdout.")(f)


def _emit(ctx, data: dict, text: str, as_json: bool) -> None:
    """Print ``data`` as JSON if asked (here or globally), else ``text``."""
    from ..io.result import _json_safe
    if as_json or _opts(ctx).json:
        click.echo(json.dumps(_json_safe(data), indent=2))
    else:
        click.echo(text)


def _note(ctx, msg: str) -> None:
    if not _opts(ctx).quiet:
        click.echo(f"inmotion: {msg}", err=True)


@contextlib.contextmanager
def _progress(ctx, desc: str):
    """A ``progress(fraction)`` callable drawing a tqdm bar on stderr (none with --quiet)."""
    if _opts(ctx).quiet:
        yield None
        return
    from tqdm import tqdm
    bar = tqdm(total=1000, desc=desc, file=sys.stderr, leave=False, disable=None,  # tty only
               bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}")

    def progress(fraction):
        bar.update(max(0, int(round(1000 * min(max(fraction, 0.0), 1.0))) - bar.n))
    try:
        yield progress
    finally:
        bar.close()


#: methods whose run takes its IMU rows in pieces (``Bundle.imu_rows_after``): the command
#: line hands them the bundle opened for reading in chunks (:mod:`inmotion.io.bundle_stream`),
#: so a run's memory does not grow with the log's length; every other method gets its
#: ``--start`` / ``--end`` window in memory, only that window's rows read (``run_method``).
#: The coarse alignments integrate their vectors block by block
#: (:func:`inmotion.align.attitude_determination.prepare`), the USQUE filters take their rows
#: block by block (``usque.run``; ``vectors: obs_vectors`` loads its window), the paper 003
#: fine filters (``od-kf``, ``ldv-kf``, ``nhc-kf``, ``fkf``) feed the engine chunk by chunk
#: (``aided_kf._feed``: only the window's rows, ``BundleStream.imu_rows_in_window``)
STREAMED = ("sins", "dr", "sins-dr", "dr-kf", "od-velocity-kf", "fine-mux", "adaptive",
            "coarse-inertial", "imada-vb", "imada-vn", "imada-dual", "mimada", "mimada-dual",
            "oba", "parked-kf", "usque", "ausque", "usque-hinf", "ausquhe", "od-kf", "ldv-kf",
            "nhc-kf", "fkf")


def _read_bundle(ctx, path, allow_imu_gaps=False, chunked=False, **kw):
    """Read a bundle (``chunked``: open it for reading in chunks, :func:`open_bundle`; ``kw``:
    :func:`read_bundle`'s), turning gap warnings into notes on stderr."""
    from ..io.bundle import BundleGapWarning
    if chunked:
        from ..io.bundle_stream import open_bundle as read_bundle
    else:
        from ..io.bundle import read_bundle
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BundleGapWarning)
        bundle = read_bundle(path, allow_imu_gaps=allow_imu_gaps, **kw)
    for w in caught:
        if issubclass(w.category, BundleGapWarning):
            _note(ctx, f"warning: {w.message}")
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return bundle


# --------------------------------------------------------------------------- the group

@click.group(cls=_Cli, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--quiet", "-q", is_flag=True, help="No progress bars or notes.")
@click.option("--json", "as_json", is_flag=True, help="Print summaries as JSON.")
@click.option("--debug", is_flag=True, help="Show tracebacks of internal failures.")
@click.version_option(package_name="inmotion")
@click.pass_context
def cli(ctx, quiet, as_json, debug):
    """In-motion alignment and navigation of land vehicles (SINS + radar / LDV / odometer)."""
    ctx.obj = _Opts(quiet, as_json, debug)


def main() -> None:
    """The command line, in-process: exits by ``SystemExit`` (0, 2 bad input, 1 internal)."""
    cli.main()


def entry() -> None:
    """Console-script entry point (``inmotion``, ``python -m inmotion``): :func:`main`, then
    :func:`fast_exit`."""
    try:
        main()
    except SystemExit as e:
        fast_exit(e.code)
    fast_exit(0)


def fast_exit(code=0) -> None:
    """End the process without tearing down the interpreter, when that is safe.

    Python's own exit destroys every module object; after a run that loaded numba and its
    LLVM objects this costs about 0.25 s of CPU (a fifth of a short command), all spent after
    the result is written. Here, when no other thread or child process is alive, the exit
    handlers (``atexit``) run and the standard streams are flushed, then ``os._exit`` ends the
    process; every file this package writes is closed before (``atomic_write``,
    ``with open``). Otherwise, or with ``INMOTION_FAST_EXIT=0``, or if flushing fails (a
    closed pipe), it raises ``SystemExit(code)`` as usual. ``code`` as ``sys.exit`` takes it.
    """
    import os
    import threading
    if code is None:
        code = 0
    elif not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    children = ("multiprocessing" in sys.modules
                and bool(sys.modules["multiprocessing"].active_children()))
    if (os.environ.get("INMOTION_FAST_EXIT") == "0" or threading.active_count() > 1
            or children):
        raise SystemExit(code)
    import atexit
    try:
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:              # e.g. BrokenPipeError: let Python report it its own way
        raise SystemExit(code) from None
    os._exit(code)


# --------------------------------------------------------------------------- simulate

def _load_scenario(name_or_path: str):
    from ..sim.scenario import find_scenario, load_scenario, shipped_scenarios
    p = Path(name_or_path)
    if not p.is_file():
        stem = name_or_path[:-5] if name_or_path.endswith(".yaml") else name_or_path
        shipped = shipped_scenarios()
        if stem not in shipped:
            from .method_docs import did_you_mean
            raise BadInput(f"no scenario file or shipped scenario named {name_or_path!r}"
                           f"{did_you_mean(stem, shipped)} ('inmotion scenarios' lists the "
                           "shipped ones)")
        try:
            p = find_scenario(name_or_path)
        except BadInput:
            raise
        except (KeyError, FileNotFoundError, ValueError) as e:
            raise BadInput(f"no scenario file or shipped scenario named {name_or_path!r} "
                           f"({e})") from None
    if not isinstance(p, (str, Path)):
        return p                       # find_scenario returned the scenario itself
    try:
        return load_scenario(p)
    except BadInput:
        raise
    except Exception as e:             # yaml / pydantic errors: the user's file is wrong
        first = str(e).strip().splitlines()
        raise BadInput(f"invalid scenario: {' '.join(first[:3])}", file=p) from None


@cli.command()
@click.argument("scenario")
@click.option("-o", "--output", required=True, type=click.Path(file_okay=False),
              help="Bundle folder to write.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Random seed (an integer >= 0).")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet"]), default="csv",
              show_default=True)
@_json_option
@click.pass_context
def simulate(ctx, scenario, output, seed, fmt, as_json):
    """Simulate SCENARIO (a YAML file or a shipped scenario name) into a bundle."""
    import numpy as np
    from ..io.bundle import write_bundle
    from ..io.safe_write import check_output_path
    from ..sim import simulate as sim
    check_output_path(output, kind="bundle")
    scen = _load_scenario(scenario)
    t0 = time.perf_counter()
    with _progress(ctx, "simulate") as progress:
        bundle = sim(scen, np.random.default_rng(seed))
        if progress:
            progress(1.0)
    sim_s = time.perf_counter() - t0
    from ..io.bundle import check_bundle
    check_bundle(bundle, f"scenario {scenario}")      # what it asks for must read back
    write_bundle(bundle, output, fmt=fmt)
    info = _bundle_info(bundle)
    info.update(bundle=str(output), seed=seed, simulate_s=sim_s)
    _emit(ctx, info, f"wrote {output}: {_info_text(info)}", as_json)


# --------------------------------------------------------------------------- info

def _distance(bundle):
    """Distance travelled [m] and where it comes from (truth, else a velocity sensor)."""
    import numpy as np
    if bundle.truth is not None:
        from ..core.metrics import _path_length
        return float(_path_length(bundle.truth, bundle.truth.t[[0, -1]])[-1]), "truth"
    for name in ("odometer", "ldv", "radar"):
        s = getattr(bundle, name)
        if s is not None:
            if s.ds is not None:
                return float(np.sum(np.abs(s.ds))), name
            return float(np.sum(np.abs(s.v[1:]) * np.diff(s.t))), name
    return None, None


def _bundle_info(bundle) -> dict:
    import numpy as np
    from ..io.bundle import TABLES, find_gaps
    tables = {}
    for name in TABLES:
        x = getattr(bundle, name)
        if x is None:
            continue
        t = x.t
        tables[name] = {"rows": int(len(t)), "start_s": float(t[0]), "end_s": float(t[-1]),
                        "rate_hz": float(1.0 / np.median(np.diff(t))) if len(t) > 1 else None,
                        "gaps": [{"row": g.row, "t_start_s": g.t_start, "t_end_s": g.t_end,
                                  "duration_s": g.duration_s} for g in find_gaps(name, t)]}
        if name in ("radar", "ldv", "odometer"):
            tables[name]["columns"] = [c for c in ("v", "ds") if getattr(x, c) is not None]
    dist, src = _distance(bundle)
    return {"name": bundle.name, "duration_s": float(bundle.imu.t[-1] - bundle.imu.t[0]),
            "distance_m": dist, "distance_from": src, "tables": tables,
            "faults": bundle.meta.get("faults") or []}


def _info_text(info: dict) -> str:
    d = info["distance_m"]
    lines = [f"{info['name']}: {info['duration_s']:.1f} s"
             + (f", {d / 1000:.3f} km (from {info['distance_from']})" if d is not None else "")]
    for name, tb in info["tables"].items():
        rate = f"{tb['rate_hz']:.4g} Hz" if tb["rate_hz"] else "-"
        extra = f" [{', '.join(tb['columns'])}]" if "columns" in tb else ""
        gaps = tb["gaps"]
        g = (f", {len(gaps)} gap(s), longest {max(x['duration_s'] for x in gaps):.3g} s "
             f"at t={gaps[0]['t_start_s']:.6g} s" if gaps else "")
        lines.append(f"  {name:9s} {tb['rows']:8d} rows  {rate:>10s}  "
                     f"{tb['start_s']:.6g} .. {tb['end_s']:.6g} s{extra}{g}")
    if info["faults"]:
        lines.append(f"  faults: {len(info['faults'])}")
        for f in info["faults"]:
            lines.append(f"    {_fault_text(f)}")
    return "\n".join(lines)


def _fault_text(f) -> str:
    """``odometer idle 200 .. 210 s (idle_speed_m_s=1)`` from a fault entry of meta.yaml."""
    if not isinstance(f, dict):
        return str(f)
    rest = {k: v for k, v in f.items() if k not in ("sensor", "kind", "start_s", "end_s")}
    span = (f"{f['start_s']:g} .. {f['end_s']:g} s"
            if isinstance(f.get("start_s"), (int, float)) and isinstance(f.get("end_s"), (int, float))
            else "")
    extra = f" ({', '.join(f'{k}={v}' for k, v in rest.items())})" if rest else ""
    return f"{f.get('sensor', '?')} {f.get('kind', '?')} {span}{extra}"


@cli.command()
@click.argument("bundle", type=click.Path())
@_json_option
@click.pass_context
def info(ctx, bundle, as_json):
    """Show what BUNDLE holds: duration, sensors and rates, distance, gaps, faults."""
    b = _read_bundle(ctx, bundle, allow_imu_gaps=True)    # info reports IMU gaps, never fails
    data = _bundle_info(b)
    _emit(ctx, data, _info_text(data), as_json)


# --------------------------------------------------------------------------- init

_ANGLE_UNITS = {"deg": math.pi / 180, "arcmin": math.pi / 180 / 60,
                "arcsec": math.pi / 180 / 3600, "rad": 1.0, "mrad": 1e-3}
_INIT_ERROR_KEYS = {"pitch": _ANGLE_UNITS, "roll": _ANGLE_UNITS, "yaw": _ANGLE_UNITS,
                    "vE": {"m/s": 1.0}, "vN": {"m/s": 1.0}, "vU": {"m/s": 1.0},
                    "north": {"m": 1.0}, "east": {"m": 1.0}, "up": {"m": 1.0}}
#: largest accepted --init-error per key (SI) and how it reads
_INIT_ERROR_LIMITS = {**{k: (math.pi, "180 deg") for k in ("pitch", "roll", "yaw")},
                      **{k: (100.0, "100 m/s") for k in ("vE", "vN", "vU")},
                      **{k: (100e3, "100 km") for k in ("north", "east", "up")}}
_ITEM = re.compile(r"^\s*([A-Za-z]+)\s*=\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
                   r"\s*([A-Za-z/]*)\s*$")


def parse_init_error(text: str) -> dict:
    """Parse ``--init-error`` into SI perturbations ``{key: value}``.

    ``'pitch=1deg,roll=-30arcmin,yaw=0.01rad,vE=0.1m/s,north=5m'``: keys pitch, roll, yaw
    (Euler angles; units deg, arcmin, arcsec, rad, mrad), vE, vN, vU (m/s), north, east, up
    (m). Every value needs its unit. Returns rad, m/s, m.
    """
    out = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        m = _ITEM.match(item)
        if not m:
            raise BadInput(f"--init-error: cannot read {item!r}; write e.g. "
                           "'pitch=1deg,roll=1deg,yaw=30arcmin'")
        key, value, unit = m.group(1), float(m.group(2)), m.group(3)
        if key not in _INIT_ERROR_KEYS:
            raise BadInput(f"--init-error: unknown key {key!r}; known: "
                           f"{', '.join(_INIT_ERROR_KEYS)}")
        units = _INIT_ERROR_KEYS[key]
        if unit not in units:
            raise BadInput(f"--init-error: {key} needs a unit in {', '.join(units)}, "
                           f"got {unit!r}")
        out[key] = value * units[unit]
        limit, what = _INIT_ERROR_LIMITS[key]
        if not math.isfinite(out[key]) or abs(out[key]) > limit:
            raise BadInput(f"--init-error: {key}={m.group(2)}{unit} is beyond {what}; an "
                           "initial error that large is not an error but another start")
    if not out:
        raise BadInput("--init-error: empty; write e.g. 'pitch=1deg,roll=1deg,yaw=1deg'")
    return out


def perturb(state, err: dict):
    """``state`` (NavState) with the SI perturbations of :func:`parse_init_error` added."""
    import numpy as np
    from ..core.earth import radii
    from ..core.solution import NavState
    euler = state.euler + np.array([err.get(k, 0.0) for k in ("pitch", "roll", "yaw")])
    vel = state.vel_n + np.array([err.get(k, 0.0) for k in ("vE", "vN", "vU")])
    r_m, r_n = radii(state.lat)
    lat = state.lat + err.get("north", 0.0) / (r_m + state.h)
    lon = state.lon + err.get("east", 0.0) / ((r_n + state.h) * np.cos(state.lat))
    return NavState.from_euler(state.t, lat, lon, state.h + err.get("up", 0.0), vel, euler)


def _init_from_meta(bundle, t0, needs_attitude):
    """Initial state from ``meta.yaml`` (:func:`inmotion.io.bundle.meta_initial`).

    Velocity defaults to rest; a method that needs attitude needs ``initial_attitude``
    (methods that find the attitude themselves get level, north-pointing and ignore it).
    """
    import numpy as np
    from ..core.solution import NavState
    from ..io.bundle import meta_initial
    ini = meta_initial(bundle.meta, "meta.yaml")
    if any(ini[k] is None for k in ("lat_deg", "lon_deg", "h_m")):
        raise BadInput("--init meta: meta.yaml has no initial position "
                       "(initial_position: {lat_deg, lon_deg, h_m})")
    if ini["euler_deg"] is None and needs_attitude:
        raise BadInput("--init meta: the method needs an initial attitude but meta.yaml has no "
                       "initial_attitude {pitch_deg, roll_deg, yaw_deg}; use --init truth or "
                       "--init RESULT (e.g. a coarse alignment's)")
    euler = np.radians(ini["euler_deg"] or [0.0, 0.0, 0.0])
    return NavState.from_euler(t0, math.radians(ini["lat_deg"]), math.radians(ini["lon_deg"]),
                               ini["h_m"], ini["vel_n_m_s"] or [0.0, 0.0, 0.0], euler)


def _initial_state(ctx, bundle, init, start, needs_attitude):
    """``(NavState or None, description)`` for ``--init truth|meta|RESULT``."""
    from ..core.solution import NavState
    if init == "truth":
        if bundle.truth is None:
            raise BadInput("--init truth: the bundle has no truth table")
        tt = bundle.truth.t
        t0 = tt[0] if start is None else start
        if not tt[0] - 1e-9 <= t0 <= tt[-1]:
            raise BadInput(f"--init truth: the truth table covers {tt[0]:.6g} .. {tt[-1]:.6g} s, "
                           f"not the start {t0:.6g} s")
        return NavState.from_truth(bundle.truth, start), "truth"
    if init == "meta":
        t0 = start if start is not None else float(bundle.imu.t[0])
        return _init_from_meta(bundle, t0, needs_attitude), "meta"
    p = Path(init)
    if not p.exists():
        raise BadInput(f"--init must be truth, meta or a result folder; {init!r} is none "
                       "of them", file=p)
    from ..io.result import read_result
    sol = read_result(p)
    t_imu = bundle.imu.t
    t0 = sol.t[-1] if start is None else start
    if not t_imu[0] - 1.0 <= t0 <= t_imu[-1]:
        what = (f"--init: the result ends at {t0:.6g} s," if start is None
                else f"--start {t0:.6g} s is")
        raise BadInput(f"{what} outside the bundle's IMU time span ({t_imu[0]:.6g} .. "
                       f"{t_imu[-1]:.6g} s): another drive or another clock?", file=p)
    if start is None:
        return sol.final_state(), f"result {p}"
    if start < sol.t[0] or start > sol.t[-1]:
        raise BadInput(f"--start {start:g} s is outside the result's time span "
                       f"({sol.t[0]:.6g} .. {sol.t[-1]:.6g} s)", file=p)
    return sol.state_at(start), f"result {p}"


# --------------------------------------------------------------------------- run a method

def _parse_sets(sets) -> dict:
    from ..io.safe_yaml import load_yaml_text
    out = {}
    for s in sets:
        key, eq, value = s.partition("=")
        if not eq or not key.strip():
            raise BadInput(f"--set {s!r}: write key=value")
        try:
            v = load_yaml_text(value, what=f"--set {key.strip()} value")
        except BadInput as e:
            if "malformed" not in e.what:
                raise
            v = value
        node = out
        parts = key.strip().split(".")
        for k in parts[:-1]:
            node = node.setdefault(k, {})
        node[parts[-1]] = v
    return out


def _merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def build_config(spec, config_file=None, mode=None, sets=()):
    """The method's pydantic configuration from a YAML/JSON file, ``--mode`` and ``--set``."""
    import pydantic
    from ..io.safe_yaml import load_yaml_file
    _, Config = spec.load()
    data = {}
    if config_file:
        p = Path(config_file)
        if not p.is_file():
            raise BadInput("configuration file does not exist", file=p)
        data = load_yaml_file(p, "YAML") or {}
        if not isinstance(data, dict):
            raise BadInput("configuration must be a mapping (key: value)", file=p)
    if mode is not None:
        data["mode"] = mode
    data = _merge(data, _parse_sets(sets))
    from ..config_checks import check_config, check_values
    try:
        check_values(data)          # NaN before pydantic: its message would not name the field
    except BadInput as e:
        raise BadInput(f"configuration of {spec.name!r}: {e.what}", file=config_file) from None
    try:
        config = Config.model_validate(data)
    except pydantic.ValidationError as e:
        errs = "; ".join(f"{'.'.join(map(str, er['loc'])) or 'config'}: {er['msg']}"
                         for er in e.errors()[:3])
        raise BadInput(f"configuration of {spec.name!r}: {errs}",
                       file=config_file) from None
    check_config(config, spec.name, file=config_file)
    return config


def _spec(method, kind=None):
    try:
        spec = registry.get(method)
    except KeyError:
        from .method_docs import did_you_mean
        names = [s.name for s in registry.methods(kind)]
        hint = did_you_mean(method, [s.name for s in registry.methods()])
        kind_text = f"{kind} " if kind else ""
        raise BadInput(f"unknown method {method!r}{hint} (known {kind_text}methods: "
                       f"{', '.join(names)}; 'inmotion methods' lists them)") from None
    if kind is not None and spec.kind != kind:
        raise BadInput(f"{method!r} is a{'n' if spec.kind == 'align' else ''} {spec.kind} "
                       f"method; use 'inmotion {spec.kind}'")
    return spec


def _accepts(run, name: str) -> bool:
    """``run`` (a method's function, :meth:`MethodSpec.load`'s wrapper) takes keyword
    ``name``."""
    import inspect
    try:
        return name in inspect.signature(run).parameters
    except (TypeError, ValueError):
        return False


def _preload(modules):
    """Import ``modules`` in a thread (joined by the caller): those the command needs only
    after the method's run, imported while the run's compiled loop, which releases the GIL,
    runs on the other core."""
    import importlib
    import threading

    from ..io import bundle_stream
    bundle_stream.one_malloc_arena()        # before the first thread (bundle_stream notes)

    def load():
        for m in modules:
            try:
                importlib.import_module(m)
            except Exception:       # noqa: BLE001 (imported again where used, errors there)
                pass
    th = threading.Thread(target=load, name="inmotion-preload", daemon=True)
    th.start()
    return th


#: modules the result's writing imports (``--format csv``; stale partial folders' glob)
_WRITE_MODULES = ("glob", "pyarrow.csv")


def run_method(ctx, bundle, spec, config, init_state, window, truth_reducer=False,
               thin_rate_hz=None):
    """Run ``spec`` on ``bundle`` cut to ``window`` = (start, end); return ``(Solution, the
    bundle it ran on)``.
    A method that streams its IMU rows (:data:`STREAMED`) takes the bundle as it is (read in
    chunks or in memory); any other takes the window in memory (:meth:`Bundle.load_window`:
    from a bundle read in chunks only the window's rows are read, so ``--start`` / ``--end``
    bound its memory).

    ``truth_reducer``: return ``(Solution, bundle, reducer)``, ``reducer`` a
    :class:`inmotion.io.bundle_stream.TruthReducer` that read the truth rows the errors need
    while the method ran (its ``result(t)`` is ``truth.reduced(t)``; the caller closes it),
    for a method that gives its output times as it makes them (keyword ``output_times``) on a
    bundle read in chunks; else None.

    ``thin_rate_hz``: the rate the caller thins the solution to afterwards
    (:func:`inmotion.io.result.thin`); a streaming method that takes a row selection
    (keyword ``select``), does not smooth and keeps no covariance history in its ``info``
    (``keep_covariance``) keeps only the rows thinning can keep
    (:func:`inmotion.io.result.thin_select`: the same rows after thinning, without holding
    the others)."""
    start, end = window
    b = (bundle.window(start, end) if spec.name in STREAMED
         else bundle.load_window(start, end, truth=True))
    if len(b.imu.t) < 2:
        t0, t1 = float(bundle.imu.t[0]), float(bundle.imu.t[-1])
        lo = f"{start:g} s" if start is not None else "the start"
        hi = f"{end:g} s" if end is not None else "the end"
        raise BadInput(f"the window from {lo} to {hi} holds fewer than 2 IMU rows; the drive "
                       f"covers {t0:g}-{t1:g} s (check --start / --end)")
    run, _ = spec.load()
    kw, reducer = {}, None
    if (thin_rate_hz is not None and spec.name in STREAMED and not getattr(config, "smooth", False)
            and not getattr(config, "keep_covariance", False) and _accepts(run, "select")):
        # (a smoothed run is smoothed at the rows kept; kept covariances are every row's)
        from ..io.result import thin_select
        kw["select"] = thin_select(thin_rate_hz)
    if (truth_reducer and spec.name in STREAMED and hasattr(b.truth, "reducer")
            and _accepts(run, "output_times")):
        reducer = b.truth.reducer()
        kw["output_times"] = reducer.feed
    t0 = time.perf_counter()
    try:
        with _progress(ctx, spec.name) as progress:
            sol = run(b, config, init_state, progress=progress, **kw)
    except BaseException:
        if reducer is not None:
            reducer.close()
        raise
    wall = time.perf_counter() - t0
    sol.info.setdefault("method", spec.name)
    sol.info.setdefault("config", config.model_dump(mode="json"))
    timing = dict(sol.info.get("timing") or {})
    timing["wall_s"] = wall
    sol.info["timing"] = timing
    return (sol, b, reducer) if truth_reducer else (sol, b)


#: default ``--output-rate`` per command [Hz]; None: every row the method outputs
DEFAULT_OUTPUT_RATE = {"navigate": 1.0, "align": None}

#: configuration fields by which a method sets its own output rate
_OUTPUT_FIELDS = ("out_stride", "output_rate_hz", "output_interval_s")


def parse_output_rate(text) -> float | None:
    """``--output-rate``: a rate in Hz (> 0), or ``all`` for every row the method outputs."""
    if text is None or isinstance(text, (int, float)):
        return text
    if str(text).strip().lower() in ("all", "every", "0"):
        return None
    try:
        rate = float(str(text).lower().removesuffix("hz"))
    except ValueError:
        raise BadInput(f"--output-rate: {text!r} is neither a rate in Hz nor 'all'") from None
    if not (rate > 0 and math.isfinite(rate)):
        raise BadInput(f"--output-rate: {text!r} must be a rate > 0 Hz, or 'all'")
    return rate


def apply_output_rate(config, bundle, rate_hz: float | None, explicit: bool):
    """``(config, thin_rate_hz)``: the configuration with its own output field set for
    ``rate_hz`` where the method has one and the user did not set it, and the rate at which to
    thin the solution afterwards (None: keep every row).

    With ``explicit`` False (the command's default rate), a method whose output field the user
    set (``--set out_stride=...``, ``--config``) keeps it and is not thinned.
    """
    import numpy as np
    fields = type(config).model_fields
    own = [f for f in _OUTPUT_FIELDS if f in fields]
    user_set = [f for f in own if f in config.model_fields_set]
    if rate_hz is None or (user_set and not explicit):
        return config, None
    if "out_stride" in own and "out_stride" not in user_set:
        dt = float(np.median(np.diff(bundle.imu.t))) if len(bundle.imu.t) > 1 else 0.0
        if dt > 0:
            stride = max(1, int(round(1.0 / (rate_hz * dt))))
            config = config.model_copy(update={"out_stride": stride})
    elif "output_rate_hz" in own and "output_rate_hz" not in user_set:
        top = getattr(config, "filter_rate_hz", rate_hz)
        config = config.model_copy(update={"output_rate_hz": min(rate_hz, top)})
    elif ("output_interval_s" in own and "output_interval_s" not in user_set
          and hasattr(config, "output_interval_for_rate") and len(bundle.imu.t) > 1):
        # a method that writes every epoch unless told (the USQUE filters) keeps only the
        # rows thinning would keep of them, without holding the others (where its epochs
        # fall on the rate's grid)
        interval = config.output_interval_for_rate(float(np.median(np.diff(bundle.imu.t))),
                                                   rate_hz)
        if interval is not None:
            config = config.model_copy(update={"output_interval_s": interval})
    return config, rate_hz


def _run_command(ctx, kind, bundle_path, method, config_file, output, init, init_error,
                 start, end, mode, sets, as_json, allow_imu_gaps=False, fmt="csv",
                 output_rate=None):
    from ..io.result import thin, write_result
    from ..io.safe_write import check_output_path
    for opt, v in (("--start", start), ("--end", end)):
        if v is not None and not math.isfinite(v):
            raise BadInput(f"{opt} {v}: not a finite time [s]")
    if start is not None and end is not None and end <= start:
        raise BadInput(f"--end {end:g} s is not after --start {start:g} s")
    spec = _spec(method, kind)
    config = build_config(spec, config_file, mode, sets)
    explicit = output_rate is not None
    rate = parse_output_rate(output_rate) if explicit else DEFAULT_OUTPUT_RATE.get(kind)
    err = parse_init_error(init_error) if init_error else None
    check_output_path(output, kind="result")
    bundle = _read_bundle(ctx, bundle_path, allow_imu_gaps, chunked=True)
    if init is None:
        init = "truth" if bundle.truth is not None else "meta"
    state, init_desc = _initial_state(ctx, bundle, init, start, spec.needs_attitude)
    if err:
        state = perturb(state, err)
    if start is None and init_desc.startswith("result"):
        start = state.t
    config, thin_rate = apply_output_rate(config, bundle, rate, explicit)
    preload = _preload(_WRITE_MODULES)
    try:
        sol, b, reducer = run_method(ctx, bundle, spec, config, state, (start, end),
                                     truth_reducer=True, thin_rate_hz=thin_rate)
    finally:
        preload.join()
    try:
        if thin_rate is not None:
            sol = thin(sol, thin_rate)
        extra = {"bundle": str(bundle_path), "bundle_name": bundle.name,
                 "init": {"from": init_desc, "error": init_error, "t_s": state.t},
                 "window": {"start_s": start, "end_s": end},
                 "output_rate_hz": thin_rate}
        truth = b.truth
        if reducer is not None:          # read while the method ran
            truth = reducer.result(sol.t)
        elif hasattr(truth, "reduced"):  # read in chunks: the rows the output's errors need
            truth = truth.reduced(sol.t)
    finally:
        if reducer is not None:
            reducer.close()
    summary = write_result(sol, output, truth=truth, summary_extra=extra, fmt=fmt)
    _emit(ctx, summary, _run_text(summary, output), as_json)


def _run_text(summary: dict, output) -> str:
    f = summary["final"]
    lines = [f"{summary['method']}: {summary['epochs']} epochs, wrote {output}",
             f"  final t={f['t_s']:.3f} s  lat={f['lat_deg']:.8f} lon={f['lon_deg']:.8f} deg "
             f"h={f['h_m']:.2f} m  yaw={f['yaw_deg']:.4f} deg"]
    if "errors" in summary:
        lines.append(_errors_text(summary["errors"]))
    lines += [f"  warning: {w}" for w in (summary.get("info") or {}).get("warnings") or []]
    return "\n".join(lines)


def _errors_text(block: dict) -> str:
    from ..core.metrics import ERROR_KEYS
    d = block["distance_m"]
    lines = [f"  errors over {block['duration_s']:.1f} s, {d / 1000:.3f} km "
             f"(estimate - truth):",
             f"  {'':14s} {'final':>12s} {'rms 100s':>12s} {'max 100s':>12s}"]
    for k in ERROR_KEYS:
        lines.append(f"  {k:14s} {block['final'][k]:12.4g} {block['rms_last_100s'][k]:12.4g} "
                     f"{block['max_abs_last_100s'][k]:12.4g}")
    if d > 0:
        lines.append(f"  horizontal error {100 * block['final']['horizontal_m'] / d:.4g} % "
                     "of distance")
    return "\n".join(lines)


def _method_options(f):
    opts = [
        click.argument("bundle", type=click.Path()),
        click.option("--method", "-m", required=True, help="Method name (inmotion methods)."),
        click.option("--config", "config_file", type=click.Path(),
                     help="YAML/JSON configuration of the method."),
        click.option("-o", "--output", required=True, type=click.Path(file_okay=False),
                     help="Result folder to write."),
        click.option("--init", default=None,
                     help="truth | meta | RESULT folder (default: truth if present, else meta)."),
        click.option("--init-error", default=None,
                     help="Perturbation, e.g. 'pitch=1deg,roll=1deg,yaw=30arcmin'."),
        click.option("--start", type=float, default=None, help="Window start [s]."),
        click.option("--end", type=float, default=None, help="Window end [s]."),
        click.option("--mode", default=None, help="Sets the configuration field 'mode'."),
        click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
                     help="Set a configuration field (repeatable)."),
        click.option("--allow-imu-gaps", is_flag=True,
                     help="Integrate across IMU gaps instead of refusing the bundle."),
        click.option("--format", "fmt", type=click.Choice(["csv", "parquet"]), default="csv",
                     show_default=True, help="Format of the result tables."),
        click.option("--output-rate", default=None, metavar="HZ|all",
                     help="Rows written per second (navigate default 1 Hz unless the method's "
                          "own out_stride / output_rate_hz is set; align default all)."),
        _json_option,
    ]
    for o in reversed(opts):
        f = o(f)
    return f


@cli.command()
@_method_options
@click.pass_context
def align(ctx, bundle, method, config_file, output, init, init_error, start, end, mode, sets,
          allow_imu_gaps, fmt, output_rate, as_json):
    """Run an alignment method on BUNDLE and write a result folder."""
    _run_command(ctx, "align", bundle, method, config_file, output, init, init_error, start, end,
                 mode, sets, as_json, allow_imu_gaps, fmt, output_rate)


@cli.command()
@_method_options
@click.pass_context
def navigate(ctx, bundle, method, config_file, output, init, init_error, start, end, mode, sets,
             allow_imu_gaps, fmt, output_rate, as_json):
    """Run a navigation method on BUNDLE and write a result folder.

    The result holds 1 row per second unless ``--output-rate`` (or the method's own
    ``out_stride`` / ``output_rate_hz``) says otherwise: a 1 h drive at 100 Hz would otherwise
    write 360 000 rows.
    """
    _run_command(ctx, "navigate", bundle, method, config_file, output, init, init_error, start,
                 end, mode, sets, as_json, allow_imu_gaps, fmt, output_rate)


# --------------------------------------------------------------------------- evaluate

@cli.command()
@click.argument("result", type=click.Path())
@click.option("--truth", "truth_bundle", required=True, type=click.Path(),
              help="Bundle with the truth table.")
@_json_option
@click.pass_context
def evaluate(ctx, result, truth_bundle, as_json):
    """Compare RESULT with the truth of a bundle; write errors.csv and the errors block.

    The bundle is opened for reading in chunks (:func:`inmotion.io.bundle_stream.open_bundle`):
    only its truth table is read, every row checked, and only the rows the result's times
    need are kept (:meth:`~inmotion.io.bundle_stream.TruthStream.reduced`), so memory stays
    flat in the length of the log (issue 13)."""
    from ..io.result import read_result, read_summary, write_errors, write_summary
    sol = read_result(result)
    bundle = _read_bundle(ctx, truth_bundle, chunked=True)
    if bundle.truth is None:
        raise BadInput("the bundle has no truth table", file=truth_bundle)
    truth = bundle.truth.reduced(sol.t)
    from ..io.safe_write import staged_folder
    summary = read_summary(result)
    with staged_folder(result, what="result") as folder:    # errors.csv and summary together
        block = write_errors(sol, truth, folder)
        summary["errors"] = block
        write_summary(summary, folder)
    _emit(ctx, {"errors": block},
          f"{summary.get('method')} on {bundle.name}:\n{_errors_text(block)}", as_json)


# --------------------------------------------------------------------------- methods

@cli.command()
@click.argument("name", required=False)
@click.option("--template", is_flag=True,
              help="With NAME: print a YAML configuration with every setting at its default "
                   "and its unit, range and meaning as comments (for --config).")
@_json_option
@click.pass_context
def methods(ctx, name, template, as_json):
    """List every method (name, kind, what it is); with NAME, that method's settings.

    ``inmotion methods NAME`` prints every setting of the method (name with its unit, default,
    allowed range, meaning), the sensors it needs, whether it needs an initial attitude, and
    its paper.
    """
    from .method_docs import config_template, method_detail, method_text
    if template and name is None:
        raise BadInput("--template needs a method NAME")
    if name is not None:
        spec = _spec(name)
        if template:
            click.echo(config_template(spec.name), nl=False)
            return
        _emit(ctx, method_detail(spec.name), method_text(spec.name), as_json)
        return
    specs = registry.methods()
    data = [{"name": s.name, "kind": s.kind, "needs_attitude": s.needs_attitude,
             "summary": s.summary} for s in specs]
    text = "\n".join(f"{s.name:20s} {s.kind:9s} {s.summary}" for s in specs)
    if as_json or _opts(ctx).json:
        click.echo(json.dumps(data, indent=2))
    else:
        click.echo(text)


# --------------------------------------------------------------------------- scenarios

def scenario_list() -> list[dict]:
    """The shipped scenarios: ``[{"name", "description", "duration_s"}]``."""
    import yaml
    from ..sim.scenario import scenario_dir, shipped_scenarios
    out = []
    for name in shipped_scenarios():
        try:
            d = yaml.safe_load((scenario_dir() / f"{name}.yaml").read_text()) or {}
        except yaml.YAMLError:
            d = {}
        out.append({"name": name, "description": str(d.get("description") or "").strip()})
    return out


@cli.command()
@_json_option
@click.pass_context
def scenarios(ctx, as_json):
    """List the shipped scenarios, one line each (simulate one with ``inmotion simulate NAME``)."""
    data = scenario_list()
    w = max(len(d["name"]) for d in data)
    _emit(ctx, data, "\n".join(f"{d['name']:{w}s}  {d['description']}" for d in data), as_json)


# --------------------------------------------------------------------------- process

def _process_init(ctx, bundle, init):
    """``(NavState or None, InitInfo dict)`` for ``process --init truth|meta|RESULT``."""
    import numpy as np
    if init is None:
        return None, {"source": "none"}
    if init == "meta":
        from ..io.bundle import meta_initial
        ini = meta_initial(bundle.meta, "meta.yaml")
        state, _ = _initial_state(ctx, bundle, "meta", None, False)
        return state, {"source": "meta", "has_attitude": ini["euler_deg"] is not None,
                       "heading_sigma_deg": 2.0, "tilt_sigma_deg": 1.0}
    state, desc = _initial_state(ctx, bundle, init, None, True)
    if init == "truth":
        return state, {"source": "truth", "has_attitude": True, "heading_sigma_deg": 0.1,
                       "tilt_sigma_deg": 0.05}
    from ..io.result import read_result
    sol = read_result(init)

    def sig(*keys):
        v = [float(np.degrees(sol.sigma[k][-1])) for k in keys
             if k in sol.sigma and len(sol.sigma[k]) and np.isfinite(sol.sigma[k][-1])]
        return max(max(v), 1e-3) if v else None
    return state, {"source": desc, "has_attitude": True,
                   "heading_sigma_deg": sig("phi_U") or 2.0,
                   "tilt_sigma_deg": sig("phi_E", "phi_N") or 1.0}


def _load_process_config(config_file, sets):
    import pydantic
    import yaml
    from ..process import ProcessConfig
    data = {}
    if config_file:
        p = Path(config_file)
        if not p.is_file():
            raise BadInput("configuration file does not exist", file=p)
        try:
            data = yaml.safe_load(p.read_text()) or {}
        except yaml.YAMLError as e:
            raise BadInput(f"malformed YAML: {str(e).splitlines()[0]}", file=p) from None
        if not isinstance(data, dict):
            raise BadInput("configuration must be a mapping (key: value)", file=p)
    data = _merge(data, _parse_sets(sets))
    try:
        return ProcessConfig.model_validate(data)
    except pydantic.ValidationError as e:
        errs = "; ".join(f"{'.'.join(map(str, er['loc'])) or 'config'}: {er['msg']}"
                         for er in e.errors()[:3])
        raise BadInput(f"process configuration: {errs}", file=config_file) from None


def run_process_to(ctx, bundle, output, cfg, init=None, fmt="csv", output_rate=None,
                   bundle_path=None, report=True) -> dict:
    """Run :func:`inmotion.process.run_process` on ``bundle``, write the result (and its HTML
    report) to ``output``; return the summary."""
    from ..io.result import thin, write_result
    from ..process import run_process
    state, ii = _process_init(ctx, bundle, init)
    rate = parse_output_rate(output_rate) if output_rate is not None else 1.0
    t0 = time.perf_counter()
    with _progress(ctx, "process") as progress:
        sol = run_process(bundle, cfg, state, ii, progress=progress, output_rate_hz=rate)
    wall = time.perf_counter() - t0
    sol.info["timing"] = {"wall_s": wall}
    if rate is not None:
        sol = thin(sol, rate)
    extra = {"bundle": str(bundle_path) if bundle_path else None, "bundle_name": bundle.name,
             "init": {"from": ii.get("source"), "t_s": None if state is None else state.t},
             "output_rate_hz": rate, "stages": sol.info.get("stages"),
             "heading": sol.info.get("heading")}
    truth = bundle.truth
    if hasattr(truth, "reduced"):        # read in chunks: the rows the output's errors need
        truth = truth.reduced(sol.t)
    summary = write_result(sol, output, truth=truth, summary_extra=extra, fmt=fmt)
    if report:
        from ..evaluate.report import build_report
        try:
            page = build_report(output)
            summary["report"] = str(page)
        except Exception as e:              # the result stands without its page
            _note(ctx, f"warning: the HTML report failed: {type(e).__name__}: {e}")
    return summary


def _stage_lines(summary: dict) -> list[str]:
    lines = []
    for s in summary.get("stages") or []:
        end = f"{s['end_s']:.2f}" if s.get("end_s") is not None else "-"
        att = s.get("attitude_end_deg") or s.get("attitude_start_deg")
        sig = s.get("sigma_end_arcmin")
        extra = ""
        if att:
            extra += f"  yaw {att['yaw'] % 360:.3f} deg"
        if sig and "phi_U" in sig:
            extra += f" (1-sigma {sig['phi_U']:.3g} arcmin)"
        lines.append(f"  {s['stage']:16s} {s['method']:22s} {s['start_s']:10.2f} .. {end:>10s} s"
                     f"{extra}\n      {s['why']}")
    h = summary.get("heading") or {}
    if h:
        lines.append(f"  heading: {h.get('source')}: {h.get('why')}")
    return lines


def _process_text(summary: dict, output) -> str:
    lines = [f"process: {summary['epochs']} epochs, wrote {output}", "stages:"]
    lines += _stage_lines(summary)
    f = summary["final"]
    lines.append(f"  final t={f['t_s']:.3f} s  lat={f['lat_deg']:.8f} lon={f['lon_deg']:.8f} deg "
                 f"h={f['h_m']:.2f} m  yaw={f['yaw_deg']:.4f} deg")
    if "errors" in summary:
        lines.append(_errors_text(summary["errors"]))
    if summary.get("report"):
        lines.append(f"  report: {summary['report']}")
    return "\n".join(lines)



def _process_bundle(ctx, bundle_path, allow_imu_gaps, init):
    """The bundle for ``process``: opened for reading in chunks
    (:func:`inmotion.io.bundle_stream.open_bundle`): its stages read the IMU rows of their
    windows or stream them (``Bundle.load_window``, ``Bundle.imu_rows_after``) and the truth
    is read for the errors only (``run_process_to``), so memory does not grow with the log.
    Where the run would take its start position from the truth (no ``--init`` and no
    position in ``meta.yaml``: :func:`inmotion.align.attitude_determination.initial_position`),
    the bundle is loaded whole as before."""
    from types import SimpleNamespace

    from ..align.attitude_determination import initial_position
    bundle = _read_bundle(ctx, bundle_path, allow_imu_gaps, chunked=True)
    if init is None and bundle.truth is not None:
        try:
            initial_position(SimpleNamespace(meta=bundle.meta, truth=None), None)
        except BadInput:                     # the position comes from the truth's first row
            bundle = _read_bundle(ctx, bundle_path, allow_imu_gaps)
    return bundle

@cli.command()
@click.argument("bundle_path", metavar="BUNDLE", type=click.Path())
@click.option("-o", "--output", required=True, type=click.Path(file_okay=False),
              help="Result folder to write.")
@click.option("--config", "config_file", type=click.Path(),
              help="YAML/JSON process configuration (inmotion.process.ProcessConfig).")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="Set a configuration field (repeatable; methods.od-kf.measurement=velocity).")
@click.option("--init", default=None,
              help="truth | meta | RESULT: start position (and the heading where the IMU "
                   "cannot find it); default: none (position from meta.yaml).")
@click.option("--start", type=float, default=None, help="Window start [s].")
@click.option("--end", type=float, default=None, help="Window end [s].")
@click.option("--smooth", is_flag=True,
              help="Forward-backward (Rauch-Tung-Striebel) smoothing of the fine-alignment "
                   "and navigation stages (the config's 'smooth').")
@click.option("--allow-imu-gaps", is_flag=True,
              help="Integrate across IMU gaps instead of refusing the bundle.")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet"]), default="csv",
              show_default=True, help="Format of the result tables.")
@click.option("--output-rate", default=None, metavar="HZ|all",
              help="Rows written per second (default 1 Hz).")
@click.option("--no-report", is_flag=True, help="Do not write the HTML report.")
@_json_option
@click.pass_context
def process(ctx, bundle_path, output, config_file, sets, init, start, end, smooth,
            allow_imu_gaps, fmt, output_rate, no_report, as_json):
    """The main job in one command: parked / moving detection, alignment, navigation.

    Finds the parked and moving segments (paper 003's chi-square test), aligns parked (coarse
    + zero-velocity fine) or in motion (coarse + fine), navigates to the end with the aiding
    the bundle has (radar: dr-kf then sins-dr; odometer / LDV: fkf, od-kf or ldv-kf; none:
    nhc-kf; barometer if present; fault detection on), and writes ONE result with the log of
    its stages (summary.json 'stages', 'heading') and report.html. An IMU that cannot
    gyrocompass (a MEMS) takes its heading from --init. Rules: ``inmotion.process``.
    """
    cfg = _load_process_config(config_file, sets)
    if smooth:
        cfg = cfg.model_copy(update={"smooth": True})
    bundle = _process_bundle(ctx, bundle_path, allow_imu_gaps, init)
    if start is not None or end is not None:
        full = bundle
        bundle = bundle.window(start, end)
        if len(bundle.imu.t) < 2:
            raise BadInput(f"the window {start} .. {end} s holds fewer than 2 IMU rows; the "
                           f"drive covers {full.imu.t[0]:g}-{full.imu.t[-1]:g} s")
    summary = run_process_to(ctx, bundle, output, cfg, init, fmt, output_rate, bundle_path,
                             report=not no_report)
    summary["window"] = {"start_s": start, "end_s": end}
    _emit(ctx, summary, _process_text(summary, output), as_json)


# --------------------------------------------------------------------------- demo

DEMO_SCENARIO = "demo"


@cli.command()
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Random seed (an integer >= 0).")
@click.option("--keep", type=click.Path(file_okay=False), default=None,
              help="Keep the bundle and results in this folder instead of a temporary one.")
@_json_option
@click.pass_context
def demo(ctx, seed, keep, as_json):
    """Simulate the built-in drive and run ``inmotion process`` on it; print its errors.

    The main job (``process``, no attitude given): its stages with the errors at the end of
    each, then, for comparison, every registered ``navigate`` method started from the first
    truth row with its default configuration (a method that does not fit the drive is skipped
    with a note; one that fails internally is reported and makes the exit status 1 after the
    tables are printed). The process result and its HTML report are in ``--keep DIR/process``.
    """
    import numpy as np
    from ..io.bundle import write_bundle
    from ..io.result import write_result
    from ..sim import simulate as sim
    if keep:
        from ..io.safe_write import check_output_path
        check_output_path(keep)
    from ..process import ProcessConfig
    with contextlib.ExitStack() as stack:
        root = Path(keep) if keep else Path(stack.enter_context(
            tempfile.TemporaryDirectory(prefix="inmotion-demo-")))
        root.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        scen = _load_scenario(DEMO_SCENARIO)
        with _progress(ctx, "simulate") as progress:
            bundle = sim(scen, np.random.default_rng(seed))
            if progress:
                progress(1.0)
        _note(ctx, f"simulated {DEMO_SCENARIO!r} in {time.perf_counter() - t0:.1f} s")
        write_bundle(bundle, root / "bundle")
        bundle = _read_bundle(ctx, root / "bundle")
        failed, proc_rows, proc = [], [], None
        try:
            try:
                proc = run_process_to(ctx, bundle, root / "process", ProcessConfig(),
                                      bundle_path=root / "bundle", report=keep is not None)
            except BadInput as e:           # e.g. a drive too short to gyrocompass
                if "--init" not in str(e):
                    raise
                _note(ctx, f"process: {e}; the demo takes the heading from the truth")
                proc = run_process_to(ctx, bundle, root / "process", ProcessConfig(),
                                      init="truth", bundle_path=root / "bundle",
                                      report=keep is not None)
            proc_rows = _demo_process_rows(proc, root / "process")
        except BadInput as e:
            _note(ctx, f"process: skipped ({e})")
        except Exception as e:
            click.echo(f"inmotion: process: internal error: {type(e).__name__}: {e}", err=True)
            failed.append("process")
        rows = []
        for spec in registry.methods("navigate"):
            try:
                config = build_config(spec)
                state, _ = _initial_state(ctx, bundle, "truth", None, spec.needs_attitude)
                sol, b = run_method(ctx, bundle, spec, config, state, (None, None))
            except BadInput as e:           # the method does not fit this drive
                _note(ctx, f"{spec.name}: skipped ({e})")
                continue
            except Exception as e:          # a broken method must not hide the others
                click.echo(f"inmotion: {spec.name}: internal error: {type(e).__name__}: {e}",
                           err=True)
                failed.append(spec.name)
                continue
            try:
                from ..io.result import check_solution
                check_solution(sol)
            except BadInput as e:           # diverged on the demo drive: the method's fault
                click.echo(f"inmotion: {spec.name}: internal error: {e}", err=True)
                failed.append(spec.name)
                continue
            summary = write_result(sol, root / spec.name, truth=b.truth,
                                   summary_extra={"bundle": str(root / "bundle")})
            rows.append(_demo_summary(spec.name, summary))
    parts = []
    if proc_rows:
        parts.append(_demo_table(proc_rows) + "\n(inmotion process, no attitude given: each "
                     "stage's errors at its end; the last row is the whole result)\n"
                     + "\n".join(_stage_lines(proc)))
    parts.append(_demo_table(rows) + "\n(for comparison: navigation from the first truth row, "
                 "every navigate method)")
    _emit(ctx, {"scenario": DEMO_SCENARIO, "seed": seed,
                "process": {"rows": proc_rows, "stages": (proc or {}).get("stages"),
                            "heading": (proc or {}).get("heading")},
                "methods": rows, "failed": failed}, "\n\n".join(parts), as_json)
    return 1 if failed else 0


def _demo_process_rows(summary: dict, folder) -> list:
    """One table row per stage of a process result (errors at the stage's end), then the
    whole result."""
    import numpy as np
    from ..io.result import find_table, read_table
    err = read_table(find_table(folder, "errors"))
    t = err["t"].to_numpy()
    rows = []
    for s in summary.get("stages") or []:
        if s.get("end_s") is None or s["stage"] == "detect" or s["end_s"] <= s["start_s"]:
            continue
        # a coarse stage's product is the attitude at its start (multiplexing): shown there
        t_at = s["start_s"] if "coarse" in s["stage"] else s["end_s"]
        k = int(min(np.searchsorted(t, t_at - 1e-6), len(t) - 1))
        e = err.iloc[k]
        d = float(e["distance_m"])
        rows.append({"method": f"{s['stage']}: {s['method'].split()[0]}",
                     "duration_s": s["end_s"] - s["start_s"], "distance_m": d,
                     "horizontal_m": float(e["horizontal_m"]),
                     "horizontal_pct": 100 * float(e["horizontal_m"]) / d if d > 0 else None,
                     "heading_arcmin": float(e["yaw_arcmin"]),
                     "level_arcmin": math.hypot(float(e["phi_E_arcmin"]),
                                                float(e["phi_N_arcmin"])),
                     "run_s": None})
    rows.append(_demo_summary("process", summary))
    return rows


def _demo_summary(name, summary) -> dict:
    e = summary["errors"]
    f = e["final"]
    d = e["distance_m"]
    return {"method": name, "duration_s": e["duration_s"], "distance_m": d,
            "horizontal_m": f["horizontal_m"],
            "horizontal_pct": 100 * f["horizontal_m"] / d if d > 0 else None,
            "heading_arcmin": f["yaw_arcmin"],
            "level_arcmin": math.hypot(f["phi_E_arcmin"], f["phi_N_arcmin"]),
            "run_s": summary["timing"].get("wall_s")}


def _demo_table(rows) -> str:
    w = max([21] + [len(r["method"]) for r in rows])
    head = (f"{'method':{w}s} {'duration s':>10s} {'distance km':>11s} {'horiz. m':>10s} "
            f"{'% dist':>8s} {'heading arcmin':>14s} {'level arcmin':>12s} {'run s':>7s}")
    lines = [head, "-" * len(head)]
    for r in rows:
        pct = f"{r['horizontal_pct']:8.3f}" if r["horizontal_pct"] is not None else f"{'-':>8s}"
        lines.append(f"{r['method']:{w}s} {r['duration_s']:10.1f} {r['distance_m'] / 1000:11.3f} "
                     f"{r['horizontal_m']:10.2f} {pct} {r['heading_arcmin']:14.3f} "
                     f"{r['level_arcmin']:12.3f} "
                     + (f"{r['run_s']:7.2f}" if r["run_s"] is not None else f"{'-':>7s}"))
    return "\n".join(lines)


from .import_cmds import export_cmd, import_cmd  # noqa: E402  (issue 9: real logs in and out)
cli.add_command(import_cmd); cli.add_command(export_cmd)

from .campaign_cmds import montecarlo, report  # noqa: E402  (issue 8: campaigns and reports)
cli.add_command(montecarlo); cli.add_command(report)

from .reproduce_cmds import reproduce  # noqa: E402  (issue 8: paper reproductions)
cli.add_command(reproduce)


if __name__ == "__main__":  # python -m inmotion.cli.main
    entry()
