"""Parked (wobbling-base) fine alignment: the 12-state zero-velocity Kalman filter, ``parked-kf``
(paper 003 sec. 2.3.1, eq. 11-13).

State (eq. 12): ``phi`` (misalignment, DESIGN convention), ``dv`` (velocity error, ENU),
``eps`` (gyro drift, b), ``nabla`` (accelerometer bias, b); position errors are ignored
(the vehicle does not move). Error equations (eq. 11, with ``v = 0``)::

    phi_dot = -[w_ie x] phi + M_dav dv - C_b^n eps - C_b^n w_g
    dv_dot  = [f_n x] phi - 2 [w_ie x] dv + C_b^n nabla + C_b^n w_a

``M_dav`` is the transport rate's dependence on velocity (``d w_en / d v`` of
:func:`inmotion.estimation.error_model.transport_jacobians`). Measurement (eq. 13):
``Z = v_SINS`` (the true velocity is zero), ``H = [0 I 0 0]``; its noise covers the base's
vibration velocity. Closed loop: after every update the attitude and velocity errors are fed
back into the SINS, the drift and bias into the IMU compensation.

The filter runs on the package's one error-state engine
(:class:`inmotion.estimation.engine.ErrorStateFilter`) with the shared error model on the
layout ``phi, dv, dp, eps, nabla``: eq. 12's twelve states plus the position error, which the
engine's model carries. The paper ignores the position error; here it is estimated but not
measured (no zero-position update, which would add information the paper's filter does not
use), so it only integrates the small residual velocity error (centimetres) and is fed back
like the rest. At rest the shared F restricted to eq. 12's states is :func:`parked_F` (a test
checks it); the ``dp`` columns add the Earth rate's dependence on latitude, negligible here.

Theoretical limits (steady state of the equations above, the errors the filter cannot see):
``phi_E = -nabla_N / g``, ``phi_N = nabla_E / g`` and ``phi_U = -eps_E / (omega_ie cos L) +
tan L nabla_E / g``, with the drift and bias resolved in n (the tests check them on a
simulated parked run).

The specific force in ``A`` (issue 15, found on the ring-laser-gyro log of PSINS)
    ``[f_n x]`` couples the heading error into the horizontal velocity through the horizontal
    specific force (``dv_E_dot = f_N phi_U - f_U phi_N``). ``A`` is built once per filter step
    (``filter_rate_hz``, 0.1 s by default) and held over the step, so ``f`` must be the mean
    specific force over that step, ``sum(dvel) / sum(dt)`` of the step's compensated rows,
    the quantity the discrete transition integrates (the engine's epoch mean). The single
    last row (``Strapdown.f_b``, 10 ms), which this filter's former own loop used, is the
    wrong one on a real parked vehicle:
    its horizontal part is accelerometer quantization (1.2 mm/s per count = 0.12 m/s^2 in
    10 ms) plus engine vibration, 0.13-0.18 m/s^2 rms, uncorrelated from one filter step to
    the next, so the model's ``int f_N phi_U dt`` random-walks (0.3 m/s rms over 300 s against
    a true heading signal of about 0.9 m/s from a 2 deg error): the filter learns a heading
    it cannot see, its heading sigma collapses and the estimate stalls (ended 7-40 arcmin
    from the integral methods with sigma 2 arcmin; from the right heading it wandered 8
    arcmin off). The simulator did not show it because its 25 Hz vibration sampled at the
    10 Hz filter epochs alternates in sign (lag-1 correlation -1), which cancels. With the
    step mean the filter lands within 0.4 arcmin of the integral methods from 0.5-10 deg
    heading starts on every 300 s window of that log.

Noise and prior defaults from the sensor specification
    ``gyro_drift_deg_h``, ``gyro_arw_deg_sqrt_h``, ``accel_bias_ug``, ``accel_vrw_ug_sqrt_hz``
    not set in the configuration are taken from ``meta['imu']`` of the bundle when it gives
    them (the simulator's spelling ``imu: {gyro: {drift_deg_h, arw_deg_sqrt_h,
    drift_markov_deg_h}, accel: {bias_ug, vrw_ug_sqrt_hz | vrw_m_s_sqrt_h, bias_markov_ug}}``,
    which the importers also write, marked ``source: documented``): a per-axis list counts
    by its largest magnitude, a Markov (instability) part is added in quadrature. The drift
    prior sets the heading sigma's floor ``sigma_eps / (omega_ie cos L)`` (unobservable
    drift), so a prior below the real sensor's makes the filter claim a heading it cannot
    have. ``Solution.info['config_source']`` says for each of these fields where its value
    came from (``config``, ``meta.imu (documented)``, ``meta.imu (simulated)``, ``default``).
"""
from __future__ import annotations

import time
from typing import Callable, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .. import config_fields as cf
from ..core import earth
from ..core.bundle import Bundle, regroup
from ..core.mechanization import _first_row
from ..core.solution import NavState, Solution
from ..errors import BadInput
from ..estimation import error_model as em
from ..estimation import measurements as ms
from ..estimation.engine import ErrorStateFilter
from ..estimation.layout import Layout, position_units
from .aided_kf import _config

__all__ = ["ParkedKfConfig", "PARKED_LAYOUT", "parked_F", "run_parked_kf",
           "spec_from_meta", "config_with_spec"]

ARCMIN = np.pi / 180.0 / 60.0
DEG_H = np.pi / 180.0 / 3600.0
UG = earth.G0 * 1e-6
#: eq. 12: the 12 states
PARKED_LAYOUT = Layout(["phi", "dv", "eps", "nabla"])
#: the engine's layout: eq. 12 plus the position error
ENGINE_LAYOUT = Layout(["phi", "dv", "dp", "eps", "nabla"])


class ParkedKfConfig(BaseModel):
    """Configuration of ``parked-kf`` (human units)."""

    model_config = ConfigDict(extra="forbid")
    filter_rate_hz: float = cf.filter_rate_hz(10.0)
    init_tilt_sigma_deg: float = cf.init_tilt_sigma_deg(0.5)
    init_heading_sigma_deg: float = cf.init_heading_sigma_deg(5.0)
    init_velocity_sigma_m_s: float = cf.init_velocity_sigma_m_s(0.1)
    gyro_drift_deg_h: float = cf.gyro_drift_deg_h(0.01)
    accel_bias_ug: float = cf.accel_bias_ug(100.0)
    gyro_arw_deg_sqrt_h: float = cf.gyro_arw_deg_sqrt_h(0.001)
    accel_vrw_ug_sqrt_hz: float = cf.accel_vrw_ug_sqrt_hz(10.0)
    zero_velocity_noise_m_s: float = Field(0.01, gt=0, description="vibration velocity")
    output_interval_s: float = cf.output_interval_s(1.0)


def parked_F(lat: float, C_nb, f_n) -> np.ndarray:
    """(12, 12) continuous ``A`` of eq. 12 (layout :data:`PARKED_LAYOUT`)."""
    lay = PARKED_LAYOUT
    w_ie, _, _, Wen_v, _, _, _ = em.transport_jacobians(float(lat), 0.0, np.zeros(3))
    F = np.zeros((lay.n, lay.n))
    F[lay["phi"], lay["phi"]] = -em.skew(w_ie)
    F[lay["phi"], lay["dv"]] = Wen_v
    F[lay["phi"], lay["eps"]] = -C_nb
    F[lay["dv"], lay["phi"]] = em.skew(np.asarray(f_n, dtype=float))
    F[lay["dv"], lay["dv"]] = -2.0 * em.skew(w_ie)
    F[lay["dv"], lay["nabla"]] = C_nb
    return F


def _prior(cfg):
    tilt, head = np.deg2rad(cfg.init_tilt_sigma_deg), np.deg2rad(cfg.init_heading_sigma_deg)
    return ENGINE_LAYOUT.diag({"phi": np.array([tilt, tilt, head]) ** 2,
                               "dv": cfg.init_velocity_sigma_m_s ** 2,
                               "eps": (cfg.gyro_drift_deg_h * DEG_H) ** 2,
                               "nabla": (cfg.accel_bias_ug * UG) ** 2})


def _noise(cfg):
    return em.ProcessNoise(gyro_arw=np.deg2rad(cfg.gyro_arw_deg_sqrt_h) / 60.0,
                           accel_vrw=cfg.accel_vrw_ug_sqrt_hz * UG)


from .meta_spec import (SPEC_FIELDS, _magnitude, config_with_spec,  # noqa: F401
                        fields_not_set, spec_from_meta)


def _first_rows(pieces, n: int):
    """The first ``n`` rows of IMU ``pieces`` (tuples of arrays), then stop: the rows after
    ``end_s`` are not read."""
    if n <= 0:
        return
    for piece in pieces:
        m = len(piece[0])
        yield piece if m <= n else tuple(x[:n] for x in piece)
        n -= m
        if n <= 0:          # (before asking the source for another piece)
            return


def run_parked_kf(bundle: Bundle, config: ParkedKfConfig | dict | None = None,
                  init: NavState | None = None, progress: Optional[Callable] = None,
                  end_s: float | None = None) -> Solution:
    """``parked-kf``: zero-velocity fine alignment of a parked vehicle (module docstring).

    ``end_s`` [s] stops the filter there (the adaptive strategy hands over when the vehicle
    drives off). Returns the SINS attitude at the output interval, ``sigma`` of ``phi`` and
    the estimated drift and bias in ``states``.
    """
    cfg, cfg_source = config_with_spec(_config(config, ParkedKfConfig), bundle.meta)
    if init is None:
        raise BadInput("parked-kf needs an initial attitude (--init truth, a coarse alignment "
                       "result, or meta.yaml)")
    t_wall = time.perf_counter()
    imu = bundle.imu                    # its times (a bundle read in chunks: no rows held)
    t_all = imu.t
    k0 = _first_row(t_all, init.t)
    k1 = len(t_all) if end_s is None else int(np.searchsorted(t_all, end_s, side="right"))
    if k1 - k0 < 2:
        raise BadInput(f"no IMU rows after the start t={init.t:.6g} s", file="imu")
    t = t_all[k0:k1]
    n_after, to_the_end = len(t_all) - k0, k1 == len(t_all)
    dt_imu = imu.dt
    del t_all
    lay = ENGINE_LAYOUT
    still = NavState(init.t, init.lat, init.lon, init.h, np.zeros(3), init.q_nb)
    step = max(1, int(round(1.0 / (cfg.filter_rate_hz * dt_imu))))
    out_every = max(1, int(round(cfg.output_interval_s / (step * dt_imu))))
    meas = [ms.ZeroVelocity(cfg.zero_velocity_noise_m_s)]
    f = ErrorStateFilter(still, lay, em.ErrorModel(lay, _noise(cfg)),
                         _prior(cfg), meas, step_rows=step,
                         out_every=out_every)
    ends = np.r_[np.arange(step - 1, len(t), step), len(t) - 1]
    t_meas = np.unique(t[ends])
    f.add_measurement("zero_velocity", t_meas)
    outs = [f.output_now()]
    chunk = step * max(1, 16384 // step)
    # the rows streamed (a bundle read in chunks reads them as they are fed, only its
    # window's: BundleStream.imu_rows_in_window), regrouped into the chunks the filter always
    # took, up to the end row
    rows_after = getattr(bundle, "imu_rows_in_window", bundle.imu_rows_after)
    n, _, pieces, _ = rows_after(init.t)
    if n != n_after:
        raise RuntimeError(f"parked-kf takes {n} IMU rows from row {k0}, not {n_after}")
    blocks = regroup(_first_rows(pieces, len(t)), chunk)
    for a in range(0, len(t), chunk):
        b = min(a + chunk, len(t))
        tc, dth, dvl = next(blocks)[:3]
        outs.append(f.add_imu(tc, dth, dvl, flush=b == len(t)))
        if progress is not None:
            progress(b / len(t))
    if to_the_end:      # none left; a reader in chunks makes its end-of-window checks (the
        for _ in pieces:    # mean specific force) when asked past the last row
            pass
    if f.epochs % out_every:                    # the last epoch is written even off the grid
        outs.append(f.output_now())
    rows = {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}
    xs = rows["x_sins"]
    sig = lay.as_dict(rows["sigma"])
    sigma = {k: sig[k] for k in ("phi_E", "phi_N", "phi_U")}
    sigma.update(vE=sig["dv_E"], vN=sig["dv_N"], vU=sig["dv_U"])
    states = lay.as_dict(rows["states"])
    nis = f.nis_sums()["zero_velocity"]
    info = {"method": "parked-kf", "config": cfg.model_dump(), "config_source": cfg_source,
            "layout": list(lay.names),
            "nis_mean_per_dof": nis[0] / max(nis[1], 1), "measurements": f.counts(),
            "nis": f.nis_summary(), "wall_time_s": time.perf_counter() - t_wall}
    return Solution.from_arrays(rows["t"], xs[:, 0:3], xs[:, 3:6], xs[:, 6:10], sigma=sigma,
                                states=states,
                                state_units=lay.unit_map(position_units(init.lat, init.h)),
                                info=info)

