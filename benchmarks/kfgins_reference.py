"""KF-GINS's filter time per hour of 100 Hz on this machine: the reference of issue 13's "14x
KF-GINS at equal work" (``bench_engine.py``'s first line).

KF-GINS (github i2Nav-WHU/KF-GINS, C++/Eigen, 21 states, ``Phi = I + F dt`` and a covariance
predict every IMU epoch, GNSS position updates) is not shipped with inmotion: give the path of a
checkout of its source. This script copies it to a temporary folder, adds a timer around the one
call that is the filter (``giengine.newImuProcess()`` in ``src/kf_gins.cpp``: mechanization,
predict, update and feedback; not its file reading and writing), builds it with CMake in Release
with ``-O3``, writes one hour of 100 Hz IMU increments (a parked IMU: gravity plus white noise;
the filter's work per epoch does not depend on the motion) and 1 Hz GNSS positions in its text
formats, and runs it ``--repeat`` times, alternating with ``bench_engine.py --no-cli`` when
``--engine`` is given so both are measured under the same load::

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src python benchmarks/kfgins_reference.py KF_GINS_SRC [--repeat 5] [--engine]

Measured 2026-12-02 18:35-18:38 UTC (AMD EPYC, 2 cores, load 0.4-1.0, alternating, 5 pairs;
the KF-GINS source of the repository's snapshot, its dataset files not needed):
KF-GINS 4.08, 4.46, 4.14, 4.86, 4.28, 4.56, 4.93, 5.86 s per hour (the first three alone);
inmotion's engine at the same workload with the default second-order Phi 0.352, 0.306, 0.371,
0.282, 0.356 s (``make bench`` minutes before: 0.266), with KF-GINS's first-order Phi 0.261,
0.253, 0.245, 0.273, 0.272 s. Ratios: default 13.7x median to median (4.51 / 0.329), 15.3x
best to best; first order 17.3x / 16.7x. The same machine gave KF-GINS 5.4-5.7 s (load 2-3)
earlier that day, and the engine 0.44 s at load ~1: the host's speed varies over the day, so a
ratio is only taken from runs side by side. This script itself, right after (``--repeat 2
--engine``, 18:39-18:41 UTC): KF-GINS 5.21, 5.04 s; the engine 0.321, 0.299 s (first order
0.323, 0.233): 16.5x median to median, 16.9x best to best (first order 18.4x / 21.6x).
Again at 19:03-19:06 UTC (``--repeat 5 --engine``, load 0.5-1.1): KF-GINS 4.80, 4.49, 4.77,
5.13, 4.37 s; the engine 0.383, 0.304, 0.317, 0.392, 0.306 s (first order 0.236, 0.233, 0.309,
0.288, 0.247): 15.0x median to median, 14.4x best to best (first order 19.3x / 18.8x). The three
series pooled (15 KF-GINS runs, 12 engine runs alternating with them): medians 4.77 s and
0.312 s, 15.3x.
"""
from __future__ import annotations

import argparse
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

TIMER = ("        auto _t0 = std::chrono::steady_clock::now();\n"
         "        giengine.newImuProcess();\n"
         "        _filt += std::chrono::duration<double>("
         "std::chrono::steady_clock::now() - _t0).count();")


def prepare(src: Path, work: Path) -> Path:
    """Copy KF-GINS's source to ``work``, add the filter timer, build it; the executable."""
    tree = work / "kfgins"
    shutil.copytree(src, tree, ignore=shutil.ignore_patterns(".git", "dataset", "bin", "build"))
    main = tree / "src" / "kf_gins.cpp"
    s = main.read_text()
    for old, new in (("#include <absl/time/clock.h>", "#include <absl/time/clock.h>\n#include <chrono>"),
                     ("        giengine.newImuProcess();", TIMER),
                     ("    double interval = endtime - starttime;",
                      "    double interval = endtime - starttime;\n    double _filt = 0.0;"),
                     ('    std::cout << "Cost " <<',
                      '    std::cout << "FILTER_S " << _filt << std::endl;\n    std::cout << "Cost " <<')):
        if old not in s:
            sys.exit(f"kfgins_reference: {main}: expected line not found: {old.strip()!r} "
                     "(a KF-GINS version this script does not know)")
        s = s.replace(old, new, 1)
    main.write_text(s)
    build = tree / "build"
    build.mkdir()
    subprocess.run(["cmake", "..", "-DCMAKE_BUILD_TYPE=Release",
                    "-DCMAKE_CXX_FLAGS=-O3 -Wno-unused-result"], cwd=build, check=True,
                   stdout=subprocess.DEVNULL)
    subprocess.run(["make", "-j2"], cwd=build, check=True, stdout=subprocess.DEVNULL)
    return tree / "bin" / "KF-GINS"


def write_inputs(work: Path, tree: Path) -> Path:
    """One hour of 100 Hz increments (KF-GINS's IMU text: time, dtheta [rad], dvel [m/s],
    forward-right-down) and 1 Hz GNSS (time, lat, lon [deg], h [m], std N, E, D [m]); the
    configuration file."""
    rng = np.random.default_rng(0)
    n, dt, g = 360_000, 0.01, 9.7936
    t = 1000.0 + dt * np.arange(1, n + 1)
    dv = rng.normal(0.0, 1e-4, (n, 3))
    dv[:, 2] -= g * dt
    np.savetxt(work / "imu.txt", np.column_stack([t, rng.normal(0.0, 1e-6, (n, 3)), dv]),
               fmt="%.9f")
    tg = np.arange(1001.0, 1000.0 + 3600.0)
    one = np.ones_like(tg)
    np.savetxt(work / "gnss.txt", np.column_stack([tg, 30.5 * one, 114.0 * one, 20.0 * one,
                                                   0.02 * one, 0.02 * one, 0.05 * one]),
               fmt="%.9f")
    (work / "out").mkdir()
    cfg = (tree / "config" / "kf-gins.yaml").read_text()
    for key, value in (("imupath", f'"{work / "imu.txt"}"'), ("gnsspath", f'"{work / "gnss.txt"}"'),
                       ("outputpath", f'"{work / "out"}"'), ("imudatarate", "100"),
                       ("starttime", "1000.5"), ("endtime", "-1")):
        cfg, k = re.subn(rf"^{key}:.*$", f"{key}: {value}", cfg, count=1, flags=re.M)
        if not k:
            sys.exit(f"kfgins_reference: no '{key}' in KF-GINS's config/kf-gins.yaml")
    path = work / "run.yaml"
    path.write_text(cfg)
    return path


def kfgins_seconds(exe: Path, cfg: Path) -> float:
    out = subprocess.run([str(exe), str(cfg)], check=True, capture_output=True, text=True).stdout
    m = re.search(r"FILTER_S ([0-9.eE+-]+)", out)
    if not m:
        sys.exit(f"kfgins_reference: no FILTER_S line in KF-GINS's output:\n{out[-500:]}")
    return float(m.group(1))


def engine_seconds() -> tuple[float, float]:
    out = subprocess.run([sys.executable, str(Path(__file__).with_name("bench_engine.py")),
                          "--no-cli", "--repeat", "3"], check=True, capture_output=True,
                         text=True).stdout
    two = re.search(r"^engine equal workload: ([0-9.]+)", out, re.M)
    one = re.search(r"^engine equal workload, first-order Phi.*: ([0-9.]+)", out, re.M)
    return float(two.group(1)), float(one.group(1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("src", type=Path, help="a checkout of KF-GINS's source")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--engine", action="store_true",
                    help="alternate with bench_engine.py --no-cli and print the ratios")
    a = ap.parse_args()
    if not (a.src / "src" / "kf_gins.cpp").is_file():
        sys.exit(f"kfgins_reference: {a.src}: not a KF-GINS source tree (no src/kf_gins.cpp)")
    with tempfile.TemporaryDirectory(prefix="kfgins-") as tmp:
        work = Path(tmp)
        exe = prepare(a.src, work)
        cfg = write_inputs(work, work / "kfgins")
        kf, e2, e1 = [], [], []
        for _ in range(a.repeat):
            kf.append(kfgins_seconds(exe, cfg))
            print(f"KF-GINS filter: {kf[-1]:.3f} s per hour", flush=True)
            if a.engine:
                two, one = engine_seconds()
                e2.append(two)
                e1.append(one)
                print(f"engine: {two:.3f} s (second-order Phi), {one:.3f} s (first order)",
                      flush=True)
        print(f"KF-GINS median {statistics.median(kf):.3f} s, best {min(kf):.3f} s per hour")
        if a.engine:
            for name, e in (("default second-order Phi", e2), ("first-order Phi", e1)):
                print(f"ratio, {name}: {statistics.median(kf) / statistics.median(e):.1f}x "
                      f"median to median, {min(kf) / min(e):.1f}x best to best")


if __name__ == "__main__":
    main()
