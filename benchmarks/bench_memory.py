"""Memory of a command-line run against the log's length: 1 h against 4 h, Parquet in, 1 Hz out.

Issue 13: "a 4 h log with 1 Hz output peaks within 15 % of a 1 h log" (the inputs are read
in chunks, :mod:`inmotion.io.bundle_stream`). The 1 h drive is the shipped
``paper002_hour`` (100 Hz IMU, 10 Hz radar and barometer, truth at 100 Hz), the 4 h drive the
same segment list driven four times over (the drive ends at rest, so it chains), both
simulated with seed 0 and written as Parquet bundles (``inmotion simulate`` in a child: this
process stays small, since a child's ``ru_maxrss`` starts from its parent's resident set).
Each is run as

    inmotion -q navigate BUNDLE --method sins-dr --init truth --set mode=velocity-position
        --set filter_rate_hz=100 --set measurement_rate_hz=10 --set output_rate_hz=1 -o OUT

in a child process; its peak resident set size (``ru_maxrss`` of that child, from
``os.wait4``) and wall time are printed, the smaller of ``--repeat`` runs after a warm-up
(numba's cache). The output (solution, states and errors at 1 Hz) grows with the log by
design; everything else should not.

The same for the main job, ``inmotion -q process BUNDLE --no-report -o OUT`` and with
``--smooth`` (the Rauch-Tung-Striebel pass stores its forward record, O(N) by nature: in
files beyond a memory budget, :class:`inmotion.estimation.smoother.ForwardRecord`): the
bundle is read in chunks, each stage reads its window's IMU rows or streams them, and the
radar stages keep only the rows of the 1 Hz output (``run_process(output_rate_hz=)``). And
one windowed alignment, ``inmotion -q align BUNDLE --method imada-vb --start 70 --end 300
-o OUT`` (the bundle's parked minute skipped): only the window's rows are read
(``BundleStream.load_window``), so its peak should not depend on the log's length at all.
And the batch alignments run to the log's end (:data:`WHOLE_ALIGN`, issue 13: ``align
--method imada-vb --start 70``, ``mimada``, ``coarse-inertial`` over the whole log, and
``usque`` from 70 s with 1 Hz updates, and with 10 Hz updates and ``output_interval_s=1``):
they read their window's rows a block at a time
(:func:`inmotion.align.attitude_determination.prepare`, ``usque._run_compiled``), so what
grows is their output and the time columns the chunked reader keeps (8 bytes per IMU and per
truth row). ``--no-process`` leaves process and align out; ``--only RUN`` (repeatable)
measures only the runs named.

And ``process --smooth`` on an odometer + LDV drive (issue 13): the same segment lists with
the radar replaced by an odometer at 10 Hz and an LDV at 100 Hz giving distance
(:data:`ODOMETER_LDV`; ``process`` runs ``fkf``, a bank of local filters, smoothed through a
central filter): the LDV's table is long and fast, so it stays on disk
(:class:`inmotion.io.bundle_stream.SpeedStream`) and is resampled chunk by chunk. On the same
drive the paper 003 fine filters run on the command line to the log's end, ``align --method
od-kf --init truth`` and ``--method fkf`` (issue 13: they feed the engine chunk by chunk,
``aided_kf._feed``, reading only their window's rows, ``BundleStream.imu_rows_in_window``;
their output is 1 Hz rows; before, with the window in memory, ``od-kf`` on the 4 h drive
peaked at 680 MiB, streamed 348 MiB, the files written byte-identical but for
summary.json's wall times). ``--no-odometer-ldv``
leaves them out.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_memory.py [--repeat N] [--no-process]
        [--no-odometer-ldv]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pyarrow.parquet as pq
import yaml

from inmotion.sim.scenario import find_scenario

OPTIONS = ["--method", "sins-dr", "--init", "truth", "--set", "mode=velocity-position",
           "--set", "filter_rate_hz=100", "--set", "measurement_rate_hz=10",
           "--set", "output_rate_hz=1"]


#: the odometer + LDV drive's sensors (those of paper 003's drive in tests/test_process_stream)
ODOMETER_LDV = {"odometer": {"rate_hz": 10.0, "pulses_per_m": 200.0,
                             "scale_factor_sigma_ppm": 2000.0, "lever_arm_m": [-0.8, -1.5, -0.9]},
                "ldv": {"rate_hz": 100.0, "output": "distance", "scale_factor_sigma_ppm": 500.0,
                        "noise_m_s": 0.01, "lever_arm_m": [0.3, 1.2, -0.6]}}


def scenario(hours: int, odometer_ldv: bool = False) -> dict:
    """``paper002_hour`` with its segment list driven ``hours`` times (with
    ``odometer_ldv``: the radar replaced by :data:`ODOMETER_LDV`, the barometer kept)."""
    sc = yaml.safe_load(Path(find_scenario("paper002_hour")).read_text())
    sc["segments"] = sc["segments"] * hours
    sc["name"] = f"paper002_{hours}h"
    if odometer_ldv:
        sc["name"] += "_odometer_ldv"
        sc["sensors"] = {**ODOMETER_LDV, "baro": sc["sensors"]["baro"]}
    return sc


#: the runs measured: label -> the command's arguments before the bundle, and after it
RUNS = {"sins-dr": (["navigate"], OPTIONS),
        "process": (["process"], ["--no-report"]),
        "process --smooth": (["process"], ["--no-report", "--smooth"]),
        "align imada-vb 70-300 s": (["align"], ["--method", "imada-vb", "--start", "70",
                                                "--end", "300"]),
        "align imada-vb 70 s-end": (["align"], ["--method", "imada-vb", "--start", "70"]),
        "align mimada 70 s-end": (["align"], ["--method", "mimada", "--start", "70"]),
        "align coarse-inertial": (["align"], ["--method", "coarse-inertial"]),
        "align usque 70 s-end, 1 Hz updates": (["align"], ["--method", "usque", "--start", "70",
                                                           "--set", "update_rate_hz=1"]),
        "align usque 70 s-end, 10 Hz updates, 1 s out": (
            ["align"], ["--method", "usque", "--start", "70", "--set", "update_rate_hz=10",
                        "--set", "output_interval_s=1"]),
        "process --smooth (odometer+LDV)": (["process"], ["--no-report", "--smooth"]),
        "align od-kf (odometer+LDV)": (["align"], ["--method", "od-kf", "--init", "truth"]),
        "align fkf (odometer+LDV)": (["align"], ["--method", "fkf", "--init", "truth"])}
#: the runs on the odometer + LDV drive (bundles ``o1``, ``o4``; the others on ``h1``, ``h4``)
ODOMETER_LDV_RUNS = ("process --smooth (odometer+LDV)", "align od-kf (odometer+LDV)",
                     "align fkf (odometer+LDV)")
#: the batch alignments run to the log's end (issue 13: they read their window in chunks,
#: :func:`inmotion.align.attitude_determination.prepare`)
WHOLE_ALIGN = ("align imada-vb 70 s-end", "align mimada 70 s-end", "align coarse-inertial",
               "align usque 70 s-end, 1 Hz updates",
               "align usque 70 s-end, 10 Hz updates, 1 s out")


def child_run(bundle: Path, out: Path, run: str = "sins-dr") -> tuple[float, float, float]:
    """``(peak RSS [MiB], wall [s], CPU [s])`` of one CLI run in a child process."""
    before, after = RUNS[run]
    cmd = [sys.executable, "-m", "inmotion.cli.main", "-q", *before, str(bundle), *after,
           "-o", str(out)]
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    err = p.stderr.read().decode()                 # (nothing with -q, unless it fails)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.stderr.close()
    if status != 0:
        raise SystemExit(f"run failed ({status}): {' '.join(cmd)}\n{err}")
    return usage.ru_maxrss / 1024.0, wall, usage.ru_utime + usage.ru_stime   # maxrss in KiB


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--no-process", action="store_true", help="measure navigate only")
    ap.add_argument("--no-odometer-ldv", action="store_true",
                    help="leave out the odometer + LDV drive")
    ap.add_argument("--only", action="append", choices=list(RUNS), metavar="RUN",
                    help="measure only this run (repeatable; one of: " + ", ".join(RUNS) + ")")
    args = ap.parse_args()
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    odometer_ldv = not (args.no_process or args.no_odometer_ldv) and (
        not args.only or any(r in ODOMETER_LDV_RUNS for r in args.only))
    radar = not args.only or any(r not in ODOMETER_LDV_RUNS for r in args.only)
    drives = ((("h", False),) if radar else ()) + ((("o", True),) if odometer_ldv else ())
    with tempfile.TemporaryDirectory() as tmp:
        for prefix, odl in drives:      # (--only: the drives of the runs named)
            for hours in (1, 4):
                # simulated by a child too: a child's ru_maxrss starts from its parent's
                # resident set at the fork, so this process must stay smaller than the runs
                sc, path = Path(tmp) / f"{prefix}{hours}.yaml", Path(tmp) / f"{prefix}{hours}"
                sc.write_text(yaml.safe_dump(scenario(hours, odl), sort_keys=False))
                subprocess.run([sys.executable, "-m", "inmotion.cli.main", "-q", "simulate",
                                str(sc), "-o", str(path), "--seed", "0", "--format", "parquet"],
                               check=True, env=env, stdout=subprocess.DEVNULL)
                size = sum(f.stat().st_size for f in path.iterdir()) / 2 ** 20
                rows = pq.ParquetFile(path / "imu.parquet").metadata.num_rows
                print(f"{hours} h drive{' (odometer+LDV)' if odl else ''}: {rows} IMU rows, "
                      f"Parquet bundle {size:.1f} MiB")
        runs_measured = ["sins-dr"] + ([] if args.no_process else
                                       ["process", "process --smooth",
                                        "align imada-vb 70-300 s", *WHOLE_ALIGN]) \
            + (list(ODOMETER_LDV_RUNS) if odometer_ldv else [])
        if args.only:
            runs_measured = [r for r in RUNS if r in args.only]
        for run in runs_measured:
            prefix = "o" if run in ODOMETER_LDV_RUNS else "h"
            child_run(Path(tmp) / f"{prefix}1", Path(tmp) / "warm", run)    # warm-up: numba
            peaks = {}
            for hours in (1, 4):
                runs = [child_run(Path(tmp) / f"{prefix}{hours}", Path(tmp) / f"out{hours}", run)
                        for _ in range(max(1, args.repeat))]
                peak, wall, cpu = (min(r[i] for r in runs) for i in range(3))
                peaks[hours] = peak
                what = (f"CLI {run} {hours} h, Parquet in, 1 Hz out" if run == "sins-dr" else
                        f"CLI {run} {hours} h, Parquet in")
                print(f"{what}: peak RSS {peak:.1f} MiB, wall {wall:.2f} s, CPU {cpu:.2f} s "
                      f"(all peaks {[round(r[0], 1) for r in runs]})")
            ratio = peaks[4] / peaks[1]
            label = "" if run == "sins-dr" else f" ({run})"
            print(f"peak RSS 4 h / 1 h{label}: {ratio:.3f} "
                  f"{'(target <= 1.15)' if run == 'sins-dr' else '(issue 13: <= 1.15)'}; "
                  f"{(peaks[4] - peaks[1]) / 3:.1f} MiB per extra hour")


if __name__ == "__main__":
    main()
