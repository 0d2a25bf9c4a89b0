"""Tuning drives for the k0 of paper 001 eq. 55 from large start headings (issue 17).

``ausquhe`` on paper 001's test-2 drive (``paper001_urban_disturbed``, LDV noise 0.3 m/s
and outlier bursts) from start headings 8, 90, 170 and -100 deg, seeds 101 and 102 (apart
from the reproduction's seeds 0...), with the attitude-only (``paper``) and the ``extended``
state, for k0 in {1, 3, 10, 30} (and k0 = 3 with gamma_max 30 deg, our default bound; the
others with gamma_max 1000 deg, i.e. no Kalman fallback). Prints per drive the mean heading
error over 181-300 s, the error at 300 s and at 100 s, and the heading 1-sigma at 300 s.
What it showed (issue 17): with the paper state a small k0 (3-10) brings ausquhe from 170
deg to within about 2 deg where k0 = 30 is still 16-20 deg off; with the extended state no k0
is robust (tens of degrees off from some starts for every k0). The reproduction's circle
then runs k0 = 3 on its own seeds (``inmotion.reproductions.paper001.CIRCLE_K0``), and
its k0 sweep (``paper001.run_k0_one``, K0_SWEEP on tuning drives from every start heading,
spawn_key (2, 2, heading, run), apart from these and from the circle's) turns this into success
rates with their intervals; its table is in the report's whole-circle section.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/usque_k0_circle.py
"""
from __future__ import annotations

import numpy as np

from inmotion import registry
from inmotion.reproductions import paper001 as m
from inmotion.sim import simulate

COMBOS = ((3.0, 30.0), (1.0, 1000.0), (3.0, 1000.0), (10.0, 1000.0), (30.0, 1000.0))
HEADINGS_DEG = (8.0, 90.0, 170.0, -100.0)
SEEDS = (101, 102)


def main(test: int = 2) -> None:
    run, Config = registry.get("ausquhe").load()
    for h in HEADINGS_DEG:
        for seed in SEEDS:
            rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(test, 0)))
            b = simulate(m._scenario(test, h), rng)
            for var in ("paper", "extended"):
                for k0, gmax in COMBOS:
                    sol = run(b, Config(**{**m.FILTER, **m.STATE_SETS[var], "k0": k0,
                                           "gamma_max_deg": gmax}), None)
                    E = m._errors_on_grid(sol, b.truth)[:, 2]
                    print(f"h={h:6.0f} s={seed} {var:9s} k0={k0:4.0f} gmax={gmax:5.0f}  "
                          f"w={E[181:].mean():8.2f} f={E[-1]:8.2f} e100={E[100]:8.2f} "
                          f"sigU300={np.degrees(sol.sigma['phi_U'][-1]):.3f}", flush=True)


if __name__ == "__main__":
    main()
