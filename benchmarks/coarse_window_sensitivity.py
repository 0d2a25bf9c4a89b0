"""Issue 15: the coarse stage's window terms, checked against finite differences through the
real coarse code path (``fine-mux``'s fault-tolerant coarse stage).

A yaw (pitch) mounting error ``mu`` is the IMU body turned by ``R = I + [mu e_z x]``: the
increments turned by ``R``, the coarse answer ``C_{b'}^n`` mapped back by ``R``, against the
plain run, is the error a vehicle velocity of ``s R^T e_y`` (= ``s (e_y + mu e_x)``) read as
``s e_y`` causes; a scale factor: the speed times ``1 + k``. The linear map
(:func:`inmotion.align.attitude_determination.window_error_map`) predicts it from the plain
run alone.

    PYTHONPATH=src python benchmarks/coarse_window_sensitivity.py 20,40,80 [seed]

Measured (issue 15, helper h15mux, seed 100, 85 s drive), heading [arcmin] for a 30 arcmin
mounting, finite difference against the linear map: yaw 20 s -0.22 / 1.7 (the first 20 s are
a constant-speed cruise: a constant offset the centred vectors remove), 40 s 436 / 560, 80 s
-205 / -218; pitch 20 s -1.05 / 0.01, 40 s 13.7 / 15.0, 80 s -5.6 / -5.1.
"""
import sys

import numpy as np

sys.path.insert(0, "tests")
from consistency_mc import drive_003  # noqa: E402

from inmotion.align import multiplex as mx  # noqa: E402
from inmotion.core import rotations  # noqa: E402
from inmotion.core.bundle import Bundle, ImuData  # noqa: E402
from inmotion.sim import simulate  # noqa: E402

ARCMIN = 180 / np.pi * 60


def coarse(b, W):
    cfg = mx.MuxConfig(coarse_window_s=W)
    t0 = mx.first_covered(b, float(b.imu.t[0]))
    t1 = mx.last_covered(b, t0 + W)
    return mx.coarse_fault_tolerant(b, cfg, None, t0, t1, error_map=True)


def turned(b, R):
    imu = ImuData(b.imu.t, b.imu.dtheta @ R.T, b.imu.dvel @ R.T)
    return Bundle(imu, b.meta, b.radar, b.ldv, b.odometer, b.baro, b.truth)


def eps(C_hat, C_ref):
    """``C_hat = (I - [eps x]) C_ref``."""
    return -rotations.vee(C_hat @ C_ref.T - np.eye(3))


if __name__ == "__main__":
    wins = [float(w) for w in sys.argv[1].split(",")]
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    b = simulate(drive_003(), np.random.default_rng(seed))
    mu = np.radians(30 / 60)
    for W in wins:
        (_, C0, emap) = coarse(b, W)
        H, s = emap["H"], emap["speed"]
        z = np.zeros_like(s)
        for name, R in (("yaw mount 30'", rotations.rot_z(mu)),
                        ("pitch mount 30'", rotations.rot_x(mu))):
            dv = s[:, None] * (R.T @ [0.0, 1.0, 0.0] - [0.0, 1.0, 0.0])[None]
            _, C1, _ = coarse(turned(b, R), W)
            fd = eps(C1 @ R, C0) * ARCMIN
            lin = np.einsum("kij,kj->i", H, dv) * ARCMIN
            print(f"W={W:g} {name}: finite difference ENU {np.round(fd, 2)}  linear map "
                  f"{np.round(lin, 2)} arcmin", flush=True)
