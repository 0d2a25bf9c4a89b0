"""Final-attitude NEES per Kalman-type method over a small Monte Carlo (issue 15): the cases of
``tests/test_consistency_nees*.py`` with their means, bands and per-run values printed, plus
the overconfident settings. Usage (from the repository root)::

    PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/nees_methods.py

About 90 s on one core. Paper 001's USQUE family (its own drive, 100 Hz, both noise
presets): ``benchmarks/nees_usque.py``.
"""
import sys
sys.path.insert(0, "tests")
from consistency_mc import *
import test_consistency_nees as A
d = drive_003(); p = parked_003()
cases = [(m, c, d, A.START_SIGMA_DEG) for m, c in [("fkf", A.PRIOR), ("od-kf", A.PRIOR), ("ldv-kf", A.PRIOR), ("nhc-kf", dict(A.PRIOR, nhc_noise_m_s=0.01)),
          ("fkf", dict(A.PRIOR, noise_preset="conservative")),
          ("fkf", dict(A.PRIOR, od_noise_m_s=[3e-5, 1e-4, 3e-5], ldv_noise_m_s=[3e-5, 5e-5, 3e-5], gyro_drift_deg_h=0.0005, accel_bias_ug=5.0))]]
cases += [("parked-kf", {"init_heading_sigma_deg": 2.0}, p, (0.5, 0.5, 2.0)), ("parked-kf", {"init_heading_sigma_deg": 2.0, "zero_velocity_noise_m_s": 1e-4}, p, (0.5, 0.5, 2.0)),
          ("sins-dr", dict(IMU_003, velocity_sensor="ldv", init_tilt_sigma_arcmin=6.0, init_heading_sigma_arcmin=30.0, speed_noise_m_s=0.01), d, (0.1, 0.1, 0.5))]
cfgv = dict(IMU_003, velocity_sensor="ldv", init_tilt_sigma_deg=0.1, init_heading_sigma_deg=0.5, velocity_noise_m_s=0.01, nhc_noise_m_s=3e-3, lateral_noise_m_s=3e-3)
cases += [("dr-kf", cfgv, d, (0.1, 0.1, 0.5)), ("od-velocity-kf", cfgv, d, (0.1, 0.1, 0.5))]
for m, c, sc, sd in cases:
    mean, band, v = final_nees(m, c, sc, 6, sd)
    extra = {k: c[k] for k in c if k in ("noise_preset", "zero_velocity_noise_m_s", "od_noise_m_s", "nhc_noise_m_s")}
    print(f"{m:15s} {extra} mean NEES {mean:.2f} band [{band[0]:.2f}, {band[1]:.2f}] runs {np.round(v, 1).tolist()}", flush=True)
