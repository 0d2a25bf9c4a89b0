"""Whether a vehicle stands still, from its IMU alone (no velocity sensor): the still period
at the start of a drive (:func:`still_start`). Used by ``inmotion process`` to plan a parked
stage and by ``nhc-kf`` to take a standing start as a stop (issue 15)."""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import BadInput
from .bundle import Bundle

__all__ = ["BLOCK_S", "still_start"]

#: the length [s] of the blocks whose means :func:`still_start` compares
BLOCK_S = 0.25


def still_start(bundle: Bundle, t0: float, accel_m_s2: float = 0.15, gyro_deg_s: float = 0.25,
                block_s: float = BLOCK_S) -> Optional[float]:
    """End [s] of the still period at the start of a drive with no velocity sensor, or None.

    The IMU alone: the 0.25 s block means of the specific force and the rate are compared
    with the mean of the blocks before them; the vehicle is still while every block stays
    within ``accel_m_s2`` and ``gyro_deg_s`` of it (driving off shows at once in the forward
    specific force, a turn in the rate; block means average the engine's vibration away).
    Returns the end of the last still block when a later one departs (None when the second
    already does, or with fewer than three blocks), the end of the last whole block when
    none departs.

    The IMU rows after ``t0`` are taken as the bundle yields them (a bundle read in chunks:
    :meth:`~inmotion.io.bundle_stream.BundleStream.imu_rows_in_window`, its window's rows a
    chunk at a time; in memory: :meth:`Bundle.imu_rows_after`) until a block departs: the
    rows are neither loaded as a window nor read past the departure.
    """
    after = getattr(bundle, "imu_rows_in_window", bundle.imu_rows_after)
    try:
        n_rows, period, pieces, _ = after(t0)
    except BadInput:
        return None
    n = max(1, int(round(block_s / period)))
    if n_rows // n < 3:
        return None
    f_sum, w_sum = np.zeros(3), np.zeros(3)
    j = 0                                   # whole blocks taken as still so far
    t_end = None                            # end [s] of the last of them
    rest = None                             # rows of a block not yet whole: (t, dth, dvl)
    t_prev = float(t0)                      # end of the interval before the next row
    for tp, dth, dvl in pieces:
        if rest is not None:
            tp, dth, dvl = (np.concatenate([a, b]) for a, b in zip(rest, (tp, dth, dvl)))
        k = len(tp) // n
        rest = (tp[k * n:], dth[k * n:], dvl[k * n:])
        if k == 0:
            continue
        ends = tp[n - 1:k * n:n]
        starts = np.r_[t_prev, ends[:-1]]
        if j == 0 and not 0.0 < tp[0] - t_prev < 2.0 * period:
            starts[0] = tp[0] - period      # no row interval before the first row
        T = ends - starts
        f = dvl[:k * n].reshape(k, n, 3).sum(1) / T[:, None]
        w = dth[:k * n].reshape(k, n, 3).sum(1) / T[:, None]
        t_prev = float(ends[-1])
        for i in range(k):
            if j > 0 and (np.abs(f[i] - f_sum / j).max() > accel_m_s2
                          or np.degrees(np.abs(w[i] - w_sum / j).max()) > gyro_deg_s):
                return t_end if j > 1 else None
            f_sum += f[i]
            w_sum += w[i]
            j += 1
            t_end = float(ends[i])
    return t_end if j >= 3 else None
