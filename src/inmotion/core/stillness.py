"""Whether a vehicle stands still, from its IMU alone (no velocity sensor): the still period
at the start of a drive (:func:`still_start`). Used by ``inmotion process`` to plan a parked
stage and by ``nhc-kf`` to take a standing start as a stop (issue 15)."""
from __future__ import annotations

from typing import Optional

import numpy as np

from .bundle import Bundle

__all__ = ["STILL_READ_ROWS", "still_start"]


#: IMU rows :func:`still_start` reads at a time
STILL_READ_ROWS = 65536


def still_start(bundle: Bundle, t0: float, accel_m_s2: float = 0.15, gyro_deg_s: float = 0.25,
                block_s: float = 0.25) -> Optional[float]:
    """End [s] of the still period at the start of a drive with no velocity sensor, or None.

    The IMU alone: the 0.25 s block means of the specific force and the rate are compared
    with the mean of the blocks before them; the vehicle is still while every block stays
    within ``accel_m_s2`` and ``gyro_deg_s`` of it (driving off shows at once in the forward
    specific force, a turn in the rate; block means average the engine's vibration away).

    The IMU rows are read a block of :data:`STILL_READ_ROWS` at a time (a bundle read in
    chunks: :meth:`Bundle.load_window`) until a block departs, not the whole log.
    """
    imu = bundle.imu
    t_all = imu.t
    k0 = int(np.searchsorted(t_all, t0 + 1e-9))
    t = t_all[k0:]
    if len(t) < 4:
        return None
    dt = np.diff(t_all[k0 - 1:] if k0 > 0 else np.r_[t[0] - imu.dt, t])
    del t_all
    n = max(1, int(round(block_s / float(np.median(dt)))))
    nb = len(t) // n
    if nb < 3:
        return None
    T = dt[:nb * n].reshape(nb, n).sum(1)
    f, w = np.empty((nb, 3)), np.empty((nb, 3))
    per = max(1, STILL_READ_ROWS // n)                # blocks read at a time
    end, j = None, 1
    for a in range(0, nb, per):
        b = min(a + per, nb)
        rows = bundle.load_window(float(t[a * n]), float(t[b * n - 1])).imu
        f[a:b] = rows.dvel.reshape(b - a, n, 3).sum(1) / T[a:b, None]
        w[a:b] = rows.dtheta.reshape(b - a, n, 3).sum(1) / T[a:b, None]
        while j < b:
            fm, wm = f[:j].mean(0), w[:j].mean(0)
            if (np.abs(f[j] - fm).max() > accel_m_s2
                    or np.degrees(np.abs(w[j] - wm).max()) > gyro_deg_s):
                end = j
                break
            j += 1
        if end is not None:
            break
    if end is None:
        return float(t[nb * n - 1])
    return float(t[end * n - 1]) if end > 1 else None
