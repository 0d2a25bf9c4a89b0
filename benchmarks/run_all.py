"""Run every ``benchmarks/bench_*.py`` and write ``benchmarks/RESULTS.md`` (``make bench``).

Each script runs alone in a subprocess with ``OPENBLAS_NUM_THREADS=1`` (and MKL's likewise),
the options below and a time budget; its printed figures are read back with the patterns of
:data:`BENCHES` and set against the issues' targets::

    | benchmark | figure | target | measured | pass/fail |

A script with no entry in :data:`BENCHES` (a new one) still runs, with no options and the
default budget; its output is kept in the file, with no figures read. A script that exits with
an error or overruns its budget fails, with the tail of its output. The file also records the
machine (CPU, cores, memory, load average before and after), the versions, the date and the
command of each script, so a figure can be re-measured alone.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/run_all.py [--only NAME ...]
        [--output FILE] [--budget-scale X]

The machine may be shared: the load average is printed beside the figures, and a figure missed
under load is reported as measured (never re-run until it passes).
"""
from __future__ import annotations

import argparse
import os
import platform
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT_BUDGET_S = 300.0


@dataclass(frozen=True)
class Figure:
    """A figure a script prints: ``pattern``'s first group is the measured number.

    ``limit`` with ``sense`` ``"<"`` (pass if measured < limit) or ``">"``; ``None``: shown
    with no target."""

    name: str
    pattern: str
    unit: str
    limit: float | None = None
    sense: str = "<"

    def target(self) -> str:
        return "-" if self.limit is None else f"{self.sense} {self.limit:g} {self.unit}"

    def verdict(self, value: float) -> str:
        if self.limit is None:
            return "-"
        ok = value < self.limit if self.sense == "<" else value > self.limit
        return "pass" if ok else "FAIL"


@dataclass(frozen=True)
class Bench:
    """How ``run_all`` runs one script: its options, its budget and the figures it reads."""

    args: tuple = ()
    budget_s: float = DEFAULT_BUDGET_S
    figures: tuple = field(default_factory=tuple)
    note: str = ""


_NUM = r"([-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)"

#: script -> how it is run and read; targets from the issues (number in the note)
BENCHES = {
    "bench_core.py": Bench(("--accuracy",), 400, (
        Figure("SINS 1 h at 100 Hz, baro damping, every row out",
               rf"strapdown, baro damping, every row out\s+{_NUM} s", "s", 1.0),
        Figure("SINS 1 h, baro damping, 1 Hz out", rf"strapdown, baro damping, 1 Hz out\s+{_NUM} s",
               "s", 1.0),
        Figure("SINS 1 h, peak allocation, 1 Hz out",
               rf"strapdown, baro damping, 1 Hz out\s+\S+ s\s+peak alloc\s+{_NUM} MiB", "MiB"),
        Figure("DR 1 h, every row out", rf"dead reckoning, every row out\s+{_NUM} s", "s", 1.0),
        Figure("DR 1 h, 1 Hz out", rf"dead reckoning, 1 Hz out\s+{_NUM} s", "s", 1.0),
        Figure("SINS vs analytic truth (1 h, perfect baro): max horizontal",
               rf"SINS, perfect baro\s+max horizontal {_NUM} m", "m", 1.0),
        Figure("DR vs analytic truth (1 h, perfect odometer): max horizontal",
               rf"DR, perfect odometer ds\s+max horizontal {_NUM} m", "m", 1.0),
    ), "issue 2: mechanization and DR of 1 h at 100 Hz under 1 s each"),
    "bench_sim.py": Bench(("--repeat", "2"), 300, (
        Figure("simulate 1 h at 100 Hz, all sensors", rf"best {_NUM} s", "s", 10.0),
        Figure("simulate 1 h: peak allocations", rf"peak allocations {_NUM} MiB", "MiB"),
    ), "issue 2: simulation of one hour with all sensors under 10 s"),
    "bench_dr_kf.py": Bench((), 300, (
        Figure("dr-kf 600 s at 100 Hz: best wall", rf"filter: best wall {_NUM} s", "s", 1.0),
        Figure("dr-kf 600 s at 100 Hz: best CPU", rf"best CPU {_NUM} s", "s", 1.0),
    ), "issue 3: one 600 s run under 1 s on one core (CPU time: what one core spends, "
       "whatever else runs)"),
    "bench_sins_dr.py": Bench(("--repeat", "2"), 400, (
        Figure("sins-dr 1 h, attitude-position", rf"attitude-position\s+{_NUM} s per run", "s", 3.0),
        Figure("sins-dr 1 h, velocity-position", rf"velocity-position\s+{_NUM} s per run", "s", 3.0),
        Figure("sins-dr 1 h, attitude-position: peak allocation",
               rf"attitude-position.*peak alloc\s+{_NUM} MiB", "MiB"),
    ), "issue 4: the one-hour drive, filter at 10 Hz, under 3 s per run on one core"),
    "bench_coarse.py": Bench((), 300, tuple(
        Figure(f"{m}: one 120 s alignment at 100 Hz", rf"^\s+{re.escape(m)}\s+{_NUM} ms", "ms", 200.0)
        for m in ("imada-vb", "imada-vn", "imada-dual", "oba", "mimada", "mimada-dual",
                  "coarse-inertial")) + (
        Figure("mimada-dual: peak allocation", rf"mimada-dual peak allocation {_NUM} MB", "MB"),
    ), "issue 5: one 120 s alignment at 100 Hz under 0.2 s on one core"),
    "bench_usque.py": Bench((), 300, tuple(
        Figure(f"{m} ({s} state): 300 s at 100 Hz", rf"^{re.escape(m)}\s+{s}\s+{_NUM}", "s",
               2.0 if m == "ausquhe" else None)
        for m in ("usque", "ausque", "usque-hinf", "ausquhe") for s in ("paper", "extended")),
        "issue 6: ausquhe, 300 s at 100 Hz, under 2 s on one core"),
    "bench_fkf.py": Bench((), 300, (
        Figure("fkf + FDI 600 s at 100 Hz: best wall", rf"filter: best wall {_NUM} s", "s", 2.0),
        Figure("fkf + FDI 600 s at 100 Hz: best CPU", rf"best CPU {_NUM} s", "s", 2.0),
    ), "issue 7: fkf with FDI over 600 s at 100 Hz under 2 s on one core"),
    "bench_montecarlo.py": Bench(("--empty-runs", "500", "--paper-runs", "10"), 900, (
        Figure("engine overhead per run, 1 worker", rf"1 worker\(s\): cluster start .*?= {_NUM} ms per run",
               "ms", 20.0),
        Figure("engine overhead per run, 2 workers", rf"2 worker\(s\): cluster start .*?= {_NUM} ms per run",
               "ms", 20.0),
        Figure("speed-up 1 -> 2 workers, CPU-bound runs",
               rf"\[2\][\s\S]*?speed-up 1 -> 2 workers: {_NUM}x", "x", 1.6, ">"),
        Figure("speed-up 1 -> 2 workers, paper 004 campaign",
               rf"\[3\][\s\S]*?speed-up 1 -> 2 workers: {_NUM}x", "x", 1.6, ">"),
    ), "issue 8: engine overhead under 20 ms per run; paper 004 near-linear 1 -> 2 workers "
       "(10 runs per point here: the per-run rate is the same as with 50)"),
    "bench_predict.py": Bench(("--calls", "10000", "--batches", "15"), 300, tuple(
        Figure(f"{lay}: {what} per call", rf"^\s+{lay}\s+{re.escape(label)}\s+{_NUM} us/call", "us",
               limit)
        for lay in ("sins-dr", "dr-kf")
        for what, label, limit in (
            ("old np.zeros + _fill_F + dense predict", "before: np.zeros + _fill_F (array form) + "
             "dense _predict_kernel", None),
            ("new _fill_F + predict_sparse", "after: _fill_F (scalar, F reused) + predict_sparse",
             None),
            ("new _fill_F", "_fill_F, scalar (after)", None),
            ("new predict_sparse", "predict_sparse (after)", 0.3))),
        "issue 13: the covariance predict of every 100 Hz epoch at about 0.3 us a call (CPU time "
        "per call, median of batches)"),
    "bench_engine.py": Bench(("--repeat", "2"), 400, (
        Figure("engine, equal workload (22 states, predict at 100 Hz, velocity + NHC at 10 Hz)",
               rf"engine equal workload: {_NUM} s CPU per hour", "s/h", 0.25),
        Figure("sins-dr, filter 100 Hz, in-process", rf"sins-dr 100 Hz in-process: {_NUM} s CPU",
               "s/h"),
        Figure("sins-dr, filter 100 Hz, smoothed, in-process",
               rf"sins-dr 100 Hz smoothed .*: {_NUM} s CPU", "s/h"),
        Figure("process --smooth, 1 h at 100 Hz, odometer", rf"process --smooth.*: {_NUM} s CPU",
               "s/h", 3.0),
        Figure("CLI sins-dr 100 Hz, Parquet in, 1 Hz out", rf"CLI sins-dr 100 Hz.*: {_NUM} s wall",
               "s", 1.0),
        Figure("CLI start-up only (inmotion --help; the fixed cost of a run is bench_startup)", rf"CLI start-up only.*: {_NUM} s wall", "s"),
    ), "issue 13: 14x KF-GINS at equal work (KF-GINS: 3.5 s CPU per hour of 100 Hz)"),
    "bench_memory.py": Bench(("--repeat", "2"), 1500, (
        Figure("CLI sins-dr 1 h, Parquet in, 1 Hz out, peak RSS",
               rf"CLI sins-dr 1 h, .*peak RSS {_NUM} MiB", "MiB"),
        Figure("CLI sins-dr 4 h, Parquet in, 1 Hz out, peak RSS",
               rf"CLI sins-dr 4 h, .*peak RSS {_NUM} MiB", "MiB"),
        Figure("peak RSS 4 h / 1 h", rf"peak RSS 4 h / 1 h: {_NUM}", "", 1.15),
        Figure("CLI process 1 h, Parquet in, peak RSS",
               rf"CLI process 1 h, .*peak RSS {_NUM} MiB", "MiB"),
        Figure("peak RSS 4 h / 1 h, process", rf"peak RSS 4 h / 1 h \(process\): {_NUM}", "",
               1.15),
        Figure("CLI process --smooth 1 h, Parquet in, peak RSS",
               rf"CLI process --smooth 1 h, .*peak RSS {_NUM} MiB", "MiB"),
        Figure("peak RSS 4 h / 1 h, process --smooth",
               rf"peak RSS 4 h / 1 h \(process --smooth\): {_NUM}", "", 1.15),
        Figure("peak RSS 4 h / 1 h, process --smooth, odometer + LDV",
               rf"peak RSS 4 h / 1 h \(process --smooth \(odometer\+LDV\)\): {_NUM}", "",
               1.15),
        Figure("peak RSS 4 h / 1 h, align imada-vb 70-300 s",
               rf"peak RSS 4 h / 1 h \(align imada-vb 70-300 s\): {_NUM}", "", 1.15),
        *(Figure(f"peak RSS 4 h / 1 h, {run}",
                 rf"peak RSS 4 h / 1 h \({re.escape(run)}\): {_NUM}", "", 1.15)
          for run in ("align imada-vb 70 s-end", "align mimada 70 s-end",
                      "align coarse-inertial", "align usque 70 s-end, 1 Hz updates",
                      "align usque 70 s-end, 10 Hz updates, 1 s out",
                      "align od-kf (odometer+LDV)", "align fkf (odometer+LDV)")),
    ), "issue 13: memory flat in log length, inputs read in chunks"),
    "bench_aot.py": Bench((), 300, (
        Figure("sins-dr loop call, JIT (numba)", rf"jit: {_NUM} ms CPU a call", "ms"),
        Figure("sins-dr loop call, ahead-of-time extension", rf"aot: {_NUM} ms CPU a call",
               "ms"),
    ), "issue 13: the ahead-of-time extension's loop against the JIT's (bit-identity printed)"),
    "bench_startup.py": Bench(("--repeat", "5"), 300, (
        Figure("CLI fixed cost (navigate sins-dr, 7 s bundle)",
               rf"CLI fixed cost \(navigate sins-dr.*: {_NUM} s wall", "s", 0.4),
        Figure("CLI fixed cost (navigate sins, 7 s bundle)",
               rf"CLI fixed cost \(navigate sins,.*: {_NUM} s wall", "s", 0.4),
        Figure("CLI fixed cost (navigate sins-dr), CPU of the run",
               rf"CLI fixed cost \(navigate sins-dr.*wall .*, {_NUM} s CPU", "s"),
        Figure("numba floor: import + first cached call, bare interpreter",
               rf"numba floor: {_NUM} s wall", "s"),
        Figure("numba floor, CPU", rf"numba floor: \S+ s wall, {_NUM} s CPU", "s"),
    ), "issue 13: a CLI run's fixed cost, measured as a real run, and numba's own floor"),
}


# ----------------------------------------------------------------------------- running
def run_script(path: Path, bench: Bench, budget_scale: float = 1.0) -> dict:
    """Run one script; return its command, exit status, wall time and output."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1",
               OMP_NUM_THREADS="1", PYTHONUNBUFFERED="1")
    cmd = [sys.executable, str(path), *bench.args]
    budget = bench.budget_s * budget_scale
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=budget,
                           cwd=HERE.parent)
        status, out, err = p.returncode, p.stdout, p.stderr
    except subprocess.TimeoutExpired as e:
        status = "timeout"
        out = (e.stdout or b"").decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        err = (e.stderr or b"").decode() if isinstance(e.stderr, bytes) else (e.stderr or "")
    return {"script": path.name, "command": "OPENBLAS_NUM_THREADS=1 .venv/bin/python "
            f"benchmarks/{path.name} {' '.join(bench.args)}".strip(), "status": status,
            "wall_s": time.perf_counter() - t0, "budget_s": budget, "stdout": out, "stderr": err}


def read_figures(bench: Bench, stdout: str) -> list:
    """``(figure, measured or None)`` for every figure of ``bench`` found in ``stdout``."""
    found = []
    for fig in bench.figures:
        m = re.search(fig.pattern, stdout, flags=re.MULTILINE)
        found.append((fig, float(m.group(1)) if m else None))
    return found


# ----------------------------------------------------------------------------- the file
def machine_info() -> dict:
    """CPU model, cores, memory, OS, Python and library versions."""
    import importlib.metadata as md
    cpu = platform.processor() or "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = "?"
    try:
        kb = int(Path("/proc/meminfo").read_text().split()[1])
        mem = f"{kb / 2 ** 20:.1f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    info = {"cpu": cpu, "cores": os.cpu_count(), "memory": mem, "os": platform.platform(),
            "python": platform.python_version()}
    for name in ("inmotion", "numpy", "scipy", "numba", "dask"):
        try:
            info[name] = md.version(name)
        except md.PackageNotFoundError:
            info[name] = "not installed"
    return info


def _cell(x) -> str:
    return str(x).replace("|", "\\|")


def results_markdown(runs: list, info: dict, load_before, load_after, started: str) -> str:
    """``RESULTS.md``: the figures table, the machine, each script's command and output."""
    L = ["# Benchmark results", "",
         f"Measured {started} by `make bench` (`benchmarks/run_all.py`); every script alone, "
         "one BLAS thread. Targets are the issues' (see each script's docstring).", "",
         "## Machine", ""]
    L += [f"- {k}: {v}" for k, v in info.items()]
    L += [f"- load average (1, 5, 15 min) before: {', '.join(f'{x:.2f}' for x in load_before)}; "
          f"after: {', '.join(f'{x:.2f}' for x in load_after)} (a shared machine makes times "
          "longer and scaling worse)", "", "## Figures", "",
          "| benchmark | figure | target | measured | pass/fail |", "| --- | --- | --- | ---: | --- |"]
    n_pass = n_fail = 0
    for r in runs:
        if r["status"] != 0:
            L.append(f"| {r['script']} | run | exit 0 within {r['budget_s']:.0f} s | "
                     f"{r['status']} after {r['wall_s']:.0f} s | FAIL |")
            n_fail += 1
        for fig, value in r["figures"]:
            v = "not printed" if value is None else f"{value:g} {fig.unit}"
            verdict = "FAIL" if value is None and r["status"] == 0 else (
                "-" if value is None else fig.verdict(value))
            n_pass += verdict == "pass"
            n_fail += verdict == "FAIL"
            L.append(f"| {r['script']} | {_cell(fig.name)} | {fig.target()} | {v} | {verdict} |")
        if not r["figures"] and r["status"] == 0:
            L.append(f"| {r['script']} | (no figures read: see its output) | - | - | - |")
    L += ["", f"{n_pass} pass, {n_fail} fail.", "", "## Each script", ""]
    for r in runs:
        L += [f"### {r['script']}", "", f"`{r['command']}`: exit {r['status']}, "
              f"{r['wall_s']:.1f} s (budget {r['budget_s']:.0f} s). {r['note']}", "", "```",
              r["stdout"].rstrip()[-6000:] or "(no output)", "```", ""]
        if r["status"] != 0 and r["stderr"].strip():
            L += ["stderr (tail):", "", "```", r["stderr"].rstrip()[-3000:], "```", ""]
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", metavar="NAME",
                    help="run only these scripts (e.g. bench_fkf.py or bench_fkf)")
    ap.add_argument("--output", default=str(HERE / "RESULTS.md"), help="the results file")
    ap.add_argument("--budget-scale", type=float, default=1.0,
                    help="multiply every time budget (a slow or busy machine)")
    args = ap.parse_args(argv)
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        want = {n if n.endswith(".py") else f"{n}.py" for n in args.only}
        unknown = want - {p.name for p in scripts}
        if unknown:
            ap.error(f"no such benchmark: {', '.join(sorted(unknown))}; have "
                     f"{', '.join(p.name for p in scripts)}")
        scripts = [p for p in scripts if p.name in want]
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    load_before = os.getloadavg()
    runs = []
    for path in scripts:
        bench = BENCHES.get(path.name, Bench(note="(no figure spec in run_all.py)"))
        print(f"{path.name} (budget {bench.budget_s * args.budget_scale:.0f} s) ...",
              file=sys.stderr, flush=True)
        r = run_script(path, bench, args.budget_scale)
        r["figures"], r["note"] = read_figures(bench, r["stdout"]), bench.note
        print(f"  exit {r['status']} in {r['wall_s']:.1f} s", file=sys.stderr, flush=True)
        runs.append(r)
    text = results_markdown(runs, machine_info(), load_before, os.getloadavg(), started)
    Path(args.output).write_text(text)
    print(f"wrote {args.output}", file=sys.stderr)
    failed = [r["script"] for r in runs if r["status"] != 0]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
