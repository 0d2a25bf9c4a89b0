"""Unscented quaternion alignment of paper 001: ``usque``, ``ausque``, ``usque-hinf``, ``ausquhe``.

In-motion alignment from an unknown attitude with a forward-velocity sensor (the paper's LDV).
The state is the attitude error as generalized Rodrigues parameters (GRP, eq. 20-22; a and f
configurable, :func:`inmotion.core.rotations.grp_from_quat`) around the quaternion of
``C_{n(t)}^i`` (``i`` = the body frame frozen at the start), optionally plus the LDV
scale-factor error ``dk``. Models: :mod:`inmotion.align.usque_model` (process eq. 9,
measurement eq. 13-14, 19, 23).

One filter cycle at each update epoch (the paper's sec. 3):

1. time update (eq. 24-33): sigma points of the error state (:class:`ScaledSigmaPoints`),
   turned into quaternions ``delta_q (x) q`` (eq. 28-29), all propagated at once through
   eq. 9, averaged (Markley, :func:`quat_average`), expressed again as GRP about the average
   (eq. 30), mean and covariance plus ``Q`` (eq. 32-33). The predicted mean GRP is folded
   into the reference quaternion and reset to zero.
2. measurement update (eq. 34-38): sigma points regenerated from the predicted covariance,
   through the measurement model; ``Y``, ``P_y``, ``P_xy``, innovation ``e``.
3. ``ausque``/``ausquhe``: adaptive ``R`` (eq. 42-45, :func:`adapt_noise`); ``P_y`` is
   recomputed with the new ``R`` before the gain.
4. state update ``X = X- + P_xy P_y^-1 e`` (eq. 50); covariance by Kalman (``usque``,
   ``ausque``), H-infinity with fixed gamma (``usque-hinf``) or adaptive gamma with bounds
   (``ausquhe``, eq. 53-56) (:mod:`inmotion.estimation.hinf`).
5. attitude update (eq. 57-59): ``q = delta_q(X) (x) mean(chi*_q)``, GRP reset.

Gamma at or below the existence floor ``gamma_a`` (``gamma^2 <= max eig(M^-1)``, eq. 54) gives
a covariance that is not positive definite, and just above it an unbounded one; with the
updates at 100 Hz, a step that only just satisfies eq. 54 repeated every 10 ms drives the
information of a weakly observable direction (the heading, in the first tens of seconds) to
zero. So an H-infinity step is taken only with ``gamma >= rho gamma_a`` (``hinf_margin``,
default 1.2): a fixed gamma below that falls back to the Kalman step, an adaptive gamma is
clamped up to it; these events are counted in ``info['hinf_floor_hits']``. With extra states
the H-infinity bound applies to the attitude error only (eq. 46 with ``S = L X``, ``L``
selecting ``dR``): the extra states are in other units (m/s^2, m/s, -), where one gamma in
rad means nothing.

The fixed gamma of ``usque-hinf`` is a bound per unit time (``gamma_deg_sqrt_s``, deg sqrt(s)).
Why: each update of eq. 53 removes ``gamma^-2`` of information from the attitude, so a gamma
given per update removes ``f_update gamma^-2`` per second: at 100 Hz, 100 times what it removes
at 1 Hz. The H-infinity cost of eq. 46 is the discretization of ``int |S - S_hat|^2 dt``, i.e.
``sum dt |S_k - S_hat_k|^2``, which puts ``dt L^T L`` in eq. 53: the gamma of one update is
``gamma_c / sqrt(dt)``. The value must satisfy the existence condition (54) over the run, not
only at each step: while the heading gets almost no information from the measurement (the
first tens of seconds, its sensitivity grows as ``g omega_ie cos(L) t^2 / 2``), the information
left of its prior ``1 / sigma_psi0^2`` after ``T0`` seconds is ``1 / sigma_psi0^2 - T0 /
gamma_c^2``, positive with the margin ``rho`` only for ``gamma_c > rho sigma_psi0 sqrt(T0)``:
1.2 * 12 deg * sqrt(50 s) = 102 deg sqrt(s) (default 100). The former default, 2 deg per update
(0.2 deg sqrt(s) at 100 Hz), violated it by a factor 500 in gamma (2.6e5 in the information
removed per second): the per-step fallback
to Kalman then held the attitude covariance at the existence boundary (heading 1-sigma pinned
at ``gamma / rho`` = 1.7 deg for the whole run), the heading forgot everything older than a
few updates, and with the extended states the filter locked onto a wrong heading compensated
by a wrong LDV scale factor and ``dv0`` (test 2 of ``reproduce_001``: heading off by 14 +- 48
deg at 181-300 s, level 37 arcmin; the covariance stayed positive definite throughout, so it was
not a loss of definiteness). With the feasible gamma no step hits the floor in either test, and
``usque-hinf`` stays close to ``usque``, as in the paper's test 2 (14.46 vs 14.51 deg).
Measured over 8 runs of test 2, extended states (RMS over the runs of the 181-300 s mean
heading error): gamma_c = 0.2 deg sqrt(s) 45 deg, 30 deg sqrt(s) 1.9 deg, 100 deg sqrt(s) 1.8
deg (``usque`` alone: 1.8 deg).

Noise presets (issue 15). ``noise_preset: matched`` (the default) is the consistent filter:
the attitude state plus ``w``, the random walk of the IMU noise the measurement integrates,
and the constants ``dk`` (LDV scale), ``nabla`` (accelerometer bias), ``eps`` (gyro drift);
the attitude's process noise ``ARW sqrt(dt)`` per update, ``w``'s from the ARW and VRW (with
its coupling to the attitude), ``R`` from the sensor's white noise, the states' priors from
the sensor specification in ``meta.yaml`` where the configuration does not set them
(:func:`resolve_noise`; ``info['config_source']`` says where each value came from); the
derivation is in :mod:`inmotion.align.usque_model` ("What the measurement's error is").
``noise_preset: paper`` keeps paper 001's own setting as configured (the reproduction passes
``sigma0_deg (3, 3, 12)``, ``process_noise_deg 1e-7``, ``meas_noise_m_s 0.07`` explicitly):
attitude state only, white ``R``. IT IS OVERCONFIDENT: over 10 runs of the paper's test 1 at
100 Hz (seeds 1000-1009) its mean attitude NEES at 300 s is 2.97e4 (``usque``, ``usque-hinf``),
5.05e4 (``ausque``) and 4.79e4 (``ausquhe``) against a band of 1.68-4.70, where the matched
preset gives 3.35, 3.35, 3.33 and 3.31 (``benchmarks/nees_usque.py --runs 10``; over the
1-s epochs of 181-300 s: paper 1.6e4-2.9e4, matched 3.12-3.15). On test 2 (LDV noise 0.3 m/s
and outlier bursts, which the sensor specification does not state) the matched preset gives
3.86, 3.85, 3.06, 3.05 (same band).

On a vehicle other than paper 001's (issue 15, session 25; ``tests/test_usque_vehicle.py``).
On paper 003's drive (an LDV giving distance, the vehicle's measured side slip and bounce,
120 s, its installation's errors zeroed, turned to a heading of 0 deg) the matched filter
was overconfident: attitude NEES 19.2 over seeds 3-8 (band 1.37-5.25), East 11.7 and up 5.8.
Three causes besides the installation (below), each now in the filter: (1) a distance sensor's mean speed was read at its
interval's end, lagging ``a T / 2`` (2.5 mm/s at 0.5 m/s^2, 100 Hz), which the heading,
seen along the forward axis through the Earth rate's ``g Omega cos(L) t^2 / 2``, took as
-2.0 to -2.5 arcmin per run: the speeds now hold at the intervals' middles
(:func:`inmotion.align.velocity_source.speed_times`); (2) the vehicle's lateral and vertical
velocity (``meta.vehicle.constraint_violation``, a Gauss-Markov process) reaches every
measurement through ``C_b^i v^b``, now in ``R`` as the white equivalent of its samples at the
update interval on the body's lateral and vertical axes (``constraint_noise_m_s``); (3) its
value at the start, which the sample taken as ``v^b(0) = [0, v, 0]`` leaves in every
measurement as a constant, is ``w``'s start on b(0)'s x and z (``constraint_start_m_s``).
Measured: NEES 3.44 (East, North, up 1.13, 1.13, 1.18); over seeds 3-12 4.51 and 13-22 5.90
(band over 10: 1.68-4.70; seed 22 ends 12 arcmin off in heading at a 2.4 arcmin sigma, 20
before (2) and (3)). (4) The installation: the vehicle moves along ``e_s = C_v^b [0, 1, 0]``
in b, not b's forward axis, and the sensor reads the speed of its own point; the family now
takes both from ``meta.yaml`` (``vehicle_mounting_arcmin``, ``lever_arms_m``:
:func:`_installation`, ``info['installation']``; paper 001 takes its LDV as calibrated in
advance, and the beam's own misalignment acts to second order). On the drive with its
installation (10 / 15 arcmin, the LDV 1.2 m ahead), heading 0 deg: NEES 3.48 over seeds 3-8
(E / N / U 1.16 / 1.12 / 1.21), 4.45 over 3-12 and 5.89 over 13-22; with ``meta.yaml``
stating none, 1005 (before, the level ended 1-2 arcmin off at a 0.2 arcmin sigma and the
heading 54-58 at 2.1). A mounting ``meta.yaml`` does not state is not estimated (no states;
a warning, the sigma floored: :func:`_unknown_mounting`). Left: a start outside the paper's
prior (paper 003's drive heads 60 deg, 5 times the 12 deg prior of ``C_b^n(0) = I``; there
the level is now within its sigma, E / N 0.7 / 2.4, and the heading 5-97 arcmin off at 4.6),
which is said (:func:`_start_check`, a warning and ``info['start_check']``).

Gamma for the matched noise (paper 001 eq. 53-55). The new noise adds process noise, which
removes information from the attitude at the rate ``I^2 ARW^2`` (``I`` the information of a
direction, ``ARW^2`` = 7.6e-13 rad^2/s on test 1); the H-infinity step removes ``gamma^-2``
per update. The existence condition (54) binds where ``I`` is smallest, the heading in the
first tens of seconds (``I ~ 1 / sigma_psi0^2`` = 23 rad^-2): there the process noise removes
4e-10 rad^-2/s, against the ``gamma_c^-2`` = 0.33 rad^-2/s of ``usque-hinf``'s default, so
the condition ``gamma_c > rho sigma_psi0 sqrt(T0)`` derived below is unchanged and the default
``gamma_deg_sqrt_s = 100`` stands. Consistency needs the information the bound removes over
the run to be small against what the filter holds: ``T gamma_c^-2 / I(T)`` = 300 s * 0.33 /
8e5 = 1e-4 for the heading at 300 s (sigma 3.7 arcmin), so ``usque-hinf``'s sigma equals
``usque``'s to 1e-4 and its NEES is ``usque``'s. For ``ausquhe`` the adaptive gamma (eq. 55)
is ``(1 + k0 r) gamma_a`` with ``r = sqrt(tr P_y / e^T e)``; ``gamma_a^2`` is the largest
attitude variance of the Kalman posterior, so each step removes ``gamma^-2 = I_min / (1 + k0
r)^2`` of information, a fraction ``1 / (1 + k0 r)^2`` of the least-informed attitude
direction's. With a matched ``R`` the innovations have ``E[e^T e] = tr P_y``, ``r ~ 1``, and
the step is a fading memory of ``tau = dt (1 + k0)^2``: the paper's per-update ``k0``
means a memory that shrinks with the update rate (``k0 = 30`` at 100 Hz: 9.6 s). For a
direction whose information grows at a steady rate ``J`` the fading gives
``dI/dt = J - I / tau``, so at time ``T`` the covariance is inflated by
``T / (tau (1 - exp(-T / tau))) ~ 1 + T / (2 tau)``; keeping that within ``1 + eps`` needs
``tau >= T / (2 eps)``: 1500 s for the paper's 300 s and ``eps = 0.1`` (``hinf_memory_s``),
i.e. ``k0 = sqrt(tau / dt) - 1`` = 386 at 100 Hz, 121 at 10 Hz (``matched`` unless ``k0`` is
set; the existence floor and ``gamma_min``/``gamma_max`` are unchanged). Measured: with
``k0 = 30`` at 100 Hz the matched ``ausquhe``'s NEES was 1.41 over 10 runs of test 1, below
its band of 1.68-4.70 (per axis E, N, U 0.22, 0.97, 0.22: the forgetting inflated the sigma);
with the derived ``k0`` it is 3.31 (per axis 0.80, 0.94, 1.57; ``benchmarks/nees_usque.py``). An outlier
(``e^T e >> tr P_y``) still brings ``gamma`` down towards ``gamma_a``, the paper's
robustness. With the paper preset ``k0 = 30`` stays (the reproduction's setting); no gamma
above the existence floor repairs a covariance that is already 1e4 times too small.

The start attitude is the paper's ``q = [1 0 0 0]`` for ``C_{n(0)}^i``, i.e. ``C_b^n(0) = I``
(pitch, roll, yaw zero); the method needs no initial attitude. The initial position comes from
``init`` (position only), else ``meta['initial_position']``, else the first truth row.
Outputs, at each update epoch: attitude ``C_b^n = (C_n^i)^T C_b^i``, the sensor velocity
``C_b^n [0, v, 0]``, dead-reckoned position, and the 1-sigma misalignment ``phi_E/N/U``
(``phi = -C_i^n dR``, the DESIGN convention; GRP with ``f = 2 (a + 1)`` equals the rotation
angle to first order).
"""
from __future__ import annotations

import time
from typing import Callable, Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..core import rotations
from ..core.bundle import Bundle
from ..core.solution import NavState, Solution
from ..errors import BadInput
from ..estimation import hinf
from ..estimation.adaptive_noise import adapt_noise
from ..estimation.layout import Block, Layout, block
from ..core.solution import StateUnit
from ..estimation.quat_average import quat_average
from ..estimation.sigma_points import ScaledSigmaPoints
from . import usque_model as model

__all__ = ["UsqueConfig", "AusqueConfig", "UsqueHinfConfig", "AusquheConfig",
           "run_usque", "run_ausque", "run_usque_hinf", "run_ausquhe", "run", "LAYOUT_ATT"]

_DEG = np.pi / 180.0
_G0 = 9.80665                   # m/s^2 per g, for ug

#: attitude error block: GRP about the reference quaternion of C_{n(t)}^i, resolved in i
ATT = Block("dR", ("x", "y", "z"), tuple(StateUnit("arcmin", 180.0 / np.pi * 60.0)
                                        for _ in range(3)))
LAYOUT_ATT = Layout([ATT])
#: error of the LDV sample taken as v^b(0) [m/s] (see inmotion.align.usque_model)
DV0 = Block("dv0", ("",), (StateUnit("m/s"),))
#: the measurement's integrated IMU noise, a random walk resolved in i [m/s]
#: (inmotion.align.usque_model, "What the measurement's error is")
W = Block("w", ("x", "y", "z"), tuple(StateUnit("m/s") for _ in range(3)))
_EXTRA_BLOCKS = {"dv0": DV0, "w": W}
#: 1-sigma of w(0) on the axes no start error reaches [m/s] (P0 positive definite)
W0_FLOOR_M_S = 1e-4
#: floor of the matched measurement noise [m/s]: the accumulator's own integration error
#: (1.1e-4 m/s at 300 s on the error-free paper001_urban drive, a drift the white R does
#: not model) with a margin
MEAS_FLOOR_M_S = 1e-3


class UsqueConfig(BaseModel):
    """Configuration of ``usque`` (and, with other defaults, its three variants).

    Attributes
    ----------
    noise_preset : {"matched", "paper"}
        ``matched`` (default): the consistent filter of the module docstring ("Noise
        presets"): states ``w``, ``dk``, ``nabla``, ``eps`` where ``estimate_*`` is None, noise
        figures from ``meta.yaml``'s sensor specification where this configuration does not
        set them (:func:`resolve_noise`). ``paper``: paper 001's setting as configured,
        attitude state only; overconfident (NEES 3e4-5e4 against a band of 1.7-4.7 over 10
        runs of the paper's test 1, where ``matched`` gives 3.3), kept to reproduce the
        paper.
    sensor : {"ldv", "radar", "odometer"}
        The forward-velocity sensor (paper: LDV).
    vectors : {"own", "obs_vectors"}
        Where the measurement comes from. ``own``: :mod:`inmotion.align.usque_model`'s
        streaming accumulation at every IMU row, exact Earth-rate term in ``h``, extra states
        possible. ``obs_vectors``: the coarse-alignment module's per-epoch OBA pairs
        (:func:`inmotion.align.obs_vectors.integrate_vectors`, ``MODEL_VB_EARTH``: paper 001
        eq. 13-19 as printed, two-sample intervals so updates at half the IMU rate, the
        Earth-rate term and ``v^n`` from its running q-method attitude, ``v^b(0)`` line-fitted
        over ``v0_fit_s``); attitude state only.
    update_rate_hz : float
        Filter update rate [Hz]; the paper's IMU and LDV run at 100 Hz and the paper states no
        other rate, so 100 Hz (an update at every IMU row of a 100 Hz bundle).
    sigma0_deg : (3,)
        Initial 1-sigma of the attitude error about i's x, y, z [deg] (paper: 3, 3, 12).
    process_noise_deg : float
        1-sigma process noise per update and axis [deg] (paper: 1e-7). The paper's value is
        far below what a gyro's angle random walk adds per update (``ARW sqrt(dt)``: 5e-6 deg
        for 0.003 deg/sqrt(h) at 100 Hz). ``noise_preset: matched`` sets it to
        ``ARW sqrt(dt)`` unless configured; ``paper`` uses the configured value (default
        1e-7, overconfident).
    gyro_arw_deg_sqrt_h, accel_vrw_ug_sqrt_hz : float
        The IMU's white-noise densities for ``w`` and the attitude's process noise
        (``matched``; from ``meta['imu']`` unless configured; defaults: paper 001's IMU).
    estimate_integrated_noise : bool or None
        The random-walk state ``w`` (3, m/s, in i) of the measurement's integrated IMU noise
        (:mod:`inmotion.align.usque_model`); None: on with ``matched``, off with ``paper``.
    meas_noise_m_s : float
        Initial 1-sigma measurement noise per axis [m/s] (paper: 0.07; ``matched``: the
        sensor's ``noise_m_s`` from ``meta.yaml`` unless configured, at least 1e-3 m/s).
    constraint_noise_m_s, constraint_start_m_s : (2,) or None
        The vehicle's lateral and vertical velocity (its constraint's violation): the white
        equivalent per update added to ``R`` on the body's lateral and vertical axes, and its
        1-sigma at the start as ``w``'s prior on b(0)'s x and z (module docstring, "On a
        vehicle other than paper 001's"); None: ``matched`` from
        ``meta['vehicle']['constraint_violation']``, ``paper`` none.
    grp_a, grp_f : float
        GRP parameters of eq. 20 (``f`` None: ``2 (a + 1)``).
    ut_sigma, ut_kappa, ut_zeta : float
        Sigma-point parameters of eq. 24-26.
    estimate_scale : bool or None
        Add the LDV scale-factor error ``dk`` to the state (paper: not estimated; None: on
        with ``matched``, off with ``paper``; the same for the two below).
    scale_sigma0_ppm : float
        Its initial 1-sigma [ppm] (``matched``: the sensor's ``scale_factor_sigma_ppm``
        unless configured; a spec of 0 turns the state off). Likewise the two below from
        ``meta['imu']``.
    estimate_accel_bias, accel_bias_sigma0_ug : bool, float
        Add the accelerometer bias ``nabla`` (b frame, random constant) with this initial
        1-sigma [ug] (not in the paper; see the report of ``reproduce_001``).
    estimate_gyro_drift, gyro_drift_sigma0_deg_h : bool, float
        Add the gyro drift ``eps`` (b frame, random constant) with this 1-sigma [deg/h].
    estimate_initial_speed_error, initial_speed_sigma0_m_s : bool, float
        Add ``dv0``, the error of the LDV sample taken as ``v^b(0)`` (see
        :mod:`inmotion.align.usque_model`), with this 1-sigma [m/s] (not in the paper).
    adaptive_r : bool
        Adaptive measurement noise (eq. 42-45).
    fading_factor : float
        ``c`` of eq. 43 (paper: 0.9 to 0.999).
    r_min_m_s, r_max_m_s : float
        Bounds of the adaptive R, as 1-sigma [m/s] (the paper gives none; chosen: 0.05 m/s,
        below the paper's initial 0.07 m/s and above the unmodelled-error floor of the
        measurement (gyro drift, integration): the LDV noise reaches only the body-forward
        axis, so on the other axes the estimate falls to the lower bound, and with 0.01 m/s
        there the filter over-trusts them and loses the heading in test 2 of
        ``reproduce_001`` (the paper preset: those correlated errors are now the state
        ``w``, so ``matched`` sets the lower bound to the sensor's own ``meas_noise_m_s``
        unless configured; with 0.05 m/s against a 0.01 m/s LDV ``ausque``'s NEES fell to
        1.0, below its band); and 1 m/s: an LDV error beyond that is a fault to
        be de-weighted, not noise to be learnt; the innovation of a wrong heading must not
        inflate R without limit, which is how an unbounded Sage-Husa estimate loses the
        heading).
    hinf : {"none", "fixed", "adaptive"}
        Covariance update: Kalman, H-infinity with fixed gamma, adaptive gamma (eq. 55-56).
    gamma_deg_sqrt_s : float
        Fixed gamma per unit time [deg sqrt(s)] (``hinf="fixed"``; the paper gives no value):
        the gamma of one update is ``gamma_deg_sqrt_s / sqrt(update interval [s])``. Default
        from the existence condition over the first 50 s (module docstring).
    k0 : float
        Coefficient of the adaptive gamma (eq. 55; "determined by experiment"). With 100 Hz
        updates each H-infinity step removes ``gamma^-2`` of information, i.e. a fraction
        ``~ 1 / (1 + k0 sqrt(tr P_y / e^T e))^2`` of the weakest direction's; ``k0 = 1`` forgets
        the heading within ~0.1 s, ``k0 = 30`` gives a memory of ~30 s (chosen on test 1,
        the undisturbed drive, from an 8-deg start). From a heading far off with a noisy
        LDV, ``k0 = 3`` does better with the attitude-only state: the H-infinity step then
        keeps the heading's covariance open against the false heading information of the
        first seconds (``inmotion reproduce 001``, section "Alignment from an unknown
        heading").
        That is the paper preset's default; ``noise_preset: matched`` derives it from
        ``hinf_memory_s`` unless set.
    hinf_memory_s : float
        ``matched``: the adaptive gamma's fading memory [s], ``k0 = sqrt(hinf_memory_s / dt)
        - 1`` (module docstring, "Gamma for the matched noise": 1500 s keeps the sigma within
        10 % of the Kalman one over a 300 s run).
    gamma_min_deg, gamma_max_deg : float
        Bounds of the adaptive gamma [deg] (eq. 55-56).
    hinf_margin : float
        ``rho > 1``: H-infinity steps only with ``gamma >= rho gamma_a`` (see ``_covariance``).
    v0_fit_s : float
        ``vectors="obs_vectors"`` only: line-fit window for ``v^b(0)`` [s] (0: raw sample).
    output_interval_s : float or None
        Spacing of the output rows [s]: every ``k``-th update epoch, ``k = max(1,
        round(output_interval_s / update interval))``, and the last; the rows are those of the
        run with every epoch kept, thinned (the filter is the same). None (default): every
        update epoch, as the paper's figures need; the result then holds a covariance per
        epoch (at 100 Hz about 0.5 GB per hour of log with the matched states), so a long
        log wants an interval: with it, and the IMU rows read a block at a time from a
        bundle read in chunks (the command line's), a run's memory does not grow with the log
        beyond its output (issue 13).
    """

    model_config = ConfigDict(extra="forbid")
    noise_preset: Literal["matched", "paper"] = Field(
        "matched",
        description="matched: a consistent filter (integrated-noise state w, IMU bias/drift and "
                    "sensor scale states, noise from meta.yaml's sensor spec where the config "
                    "does not set it); paper: paper 001's settings as configured, attitude "
                    "state only (overconfident: NEES 3e4-5e4 against a band of 1.7-4.7 on "
                    "the paper's test 1; matched: 3.3)")
    sensor: Literal["auto", "ldv", "radar", "odometer"] = Field(
        "auto", description="forward-velocity sensor of the measurement; auto: the first present "
                            "of ldv (the paper's), radar, odometer (info: sensor)")
    vectors: Literal["own", "obs_vectors"] = Field(
        "own",
        description="measurement source: own (streaming, exact Earth-rate term) or obs_vectors "
                    "(paper 001 eq. 13-19 as printed)")
    update_rate_hz: float = Field(
        100.0, gt=0, description="filter update rate [Hz] (paper: 100, every IMU row)")
    sigma0_deg: tuple[float, float, float] = Field(
        (3.0, 3.0, 12.0),
        description="initial 1-sigma attitude error about x, y, z [deg] (paper: 3, 3, 12)")
    process_noise_deg: float = Field(
        1e-7, ge=0,
        description="1-sigma process noise per update and axis [deg] (paper: 1e-7, overconfident;"
                    " noise_preset matched: ARW*sqrt(dt) unless set)")
    constraint_noise_m_s: Optional[tuple[float, float]] = Field(
        None,
        description="1-sigma [m/s] of the vehicle's lateral and vertical velocity at the "
                    "sensor (its constraint's violation: side slip, bounce) as white noise "
                    "per update, added to R on the body's lateral and vertical axes; None: "
                    "matched takes the white equivalent of meta.vehicle.constraint_violation "
                    "at the update interval (none without one), paper none")
    constraint_start_m_s: Optional[tuple[float, float]] = Field(
        None,
        description="1-sigma [m/s] of the vehicle's lateral and vertical velocity at the start "
                    "(the violation at the sample taken as v^b(0), a constant error of every "
                    "measurement): the prior of the integrated-noise state w on b(0)'s x and z; "
                    "None: matched takes meta.vehicle.constraint_violation's 1-sigma")
    meas_noise_m_s: float = Field(
        0.07, gt=0,
        description="initial 1-sigma measurement noise per axis [m/s] (paper: 0.07)")
    grp_a: float = Field(1.0, ge=0, le=1, description="GRP parameter a of paper 001 eq. 20")
    grp_f: Optional[float] = Field(
        None, gt=0, description="GRP parameter f of eq. 20; None: 2 (a + 1)")
    ut_sigma: float = Field(
        1.0, gt=0, le=1, description="sigma-point spread parameter of eq. 24-26")
    ut_kappa: float = Field(0.0, ge=0, description="sigma-point parameter kappa of eq. 24-26")
    ut_zeta: float = Field(2.0, description="sigma-point parameter zeta of eq. 24-26")
    estimate_scale: Optional[bool] = Field(
        None,
        description="add the velocity sensor's scale-factor error dk to the state (paper: no; "
                    "None: yes with noise_preset matched)")
    scale_sigma0_ppm: float = Field(1000.0, gt=0, description="initial 1-sigma of dk [ppm]")
    estimate_accel_bias: Optional[bool] = Field(
        None, description="add the accelerometer bias to the state (not in the paper; None: yes "
                          "with noise_preset matched)")
    accel_bias_sigma0_ug: float = Field(
        100.0, gt=0, description="initial 1-sigma of the accelerometer bias [ug]")
    estimate_gyro_drift: Optional[bool] = Field(
        None, description="add the gyro drift to the state (not in the paper; None: yes with "
                          "noise_preset matched)")
    estimate_integrated_noise: Optional[bool] = Field(
        None, description="add w, the random walk of the IMU noise the measurement integrates "
                          "(not in the paper; None: yes with noise_preset matched)")
    gyro_arw_deg_sqrt_h: float = Field(
        0.003, ge=0, description="gyro angle random walk [deg/sqrt(h)] (noise_preset matched; "
                                 "meta.yaml's imu spec where the config does not set it)")
    accel_vrw_ug_sqrt_hz: float = Field(
        50.0, ge=0, description="accelerometer velocity random walk [ug/sqrt(Hz)] (noise_preset "
                                "matched; meta.yaml's imu spec where the config does not set it)")
    gyro_drift_sigma0_deg_h: float = Field(
        0.01, gt=0, description="initial 1-sigma of the gyro drift [deg/h]")
    estimate_initial_speed_error: bool = Field(
        False,
        description="add dv0, the error of the sample taken as v^b(0) (not in the paper)")
    initial_speed_sigma0_m_s: float = Field(0.1, gt=0, description="initial 1-sigma of dv0 [m/s]")
    adaptive_r: bool = Field(
        False,
        description="adaptive measurement noise with a fading factor (paper 001 eq. 42-45)")
    fading_factor: float = Field(
        0.99, gt=0, lt=1,
        description="fading factor c of the adaptive R, eq. 43 (paper: 0.9 to 0.999)")
    r_min_m_s: float = Field(
        0.05, gt=0, description="lower bound of the adaptive R as 1-sigma [m/s]")
    r_max_m_s: float = Field(
        1.0, gt=0, description="upper bound of the adaptive R as 1-sigma [m/s]")
    hinf: Literal["none", "fixed", "adaptive"] = Field(
        "none",
        description="covariance update: none (Kalman), fixed (H-infinity, fixed gamma) or "
                    "adaptive (eq. 55-56)")
    gamma_deg_sqrt_s: float = Field(
        100.0, gt=0,
        description="fixed H-infinity gamma per unit time [deg sqrt(s)] (hinf = fixed)")
    k0: float = Field(
        30.0, gt=0,
        description="coefficient of the adaptive gamma, eq. 55 (30: ~30 s memory)")
    hinf_memory_s: float = Field(
        1500.0, gt=0,
        description="noise_preset matched: the adaptive gamma's memory [s]; k0 = "
                    "sqrt(hinf_memory_s / update interval) - 1 unless k0 is set")
    gamma_min_deg: float = Field(0.1, gt=0, description="lower bound of the adaptive gamma [deg]")
    gamma_max_deg: float = Field(30.0, gt=0, description="upper bound of the adaptive gamma [deg]")
    hinf_margin: float = Field(
        1.2, gt=1,
        description="H-infinity steps only with gamma >= hinf_margin * gamma_a (> 1)")
    v0_fit_s: float = Field(
        1.0, ge=0,
        description="vectors = obs_vectors only: line-fit window for v^b(0) [s] (0: raw sample)")
    output_interval_s: Optional[float] = Field(
        None, gt=0,
        description="spacing of the output rows [s]: every k-th update epoch, k the nearest "
                    "integer (and the last); None: every update epoch (a covariance per "
                    "epoch: memory grows with the log)")

    def output_interval_for_rate(self, dt_imu: float, rate_hz: float) -> Optional[float]:
        """The ``output_interval_s`` whose rows are those :func:`inmotion.io.result.thin` at
        ``rate_hz`` keeps of the every-epoch run (``1 / rate_hz`` when it is a whole number of
        update intervals of an IMU of period ``dt_imu`` [s]), else None (every epoch)."""
        stride = (2 if self.vectors == "obs_vectors"
                  else max(1, int(round(1.0 / (self.update_rate_hz * dt_imu)))))
        k = 1.0 / (rate_hz * stride * dt_imu)
        return 1.0 / rate_hz if round(k) >= 1 and abs(k - round(k)) < 1e-6 else None


class AusqueConfig(UsqueConfig):
    """``ausque``: USQUE with the adaptive measurement noise (eq. 38-45)."""
    adaptive_r: bool = Field(
        True,
        description="adaptive measurement noise with a fading factor (paper 001 eq. 42-45)")


class UsqueHinfConfig(UsqueConfig):
    """``usque-hinf``: USQUE with the H-infinity covariance update, fixed gamma (eq. 46-52)."""
    hinf: Literal["none", "fixed", "adaptive"] = Field(
        "fixed",
        description="covariance update: none (Kalman), fixed (H-infinity, fixed gamma) or "
                    "adaptive (eq. 55-56)")


class AusquheConfig(UsqueConfig):
    """``ausquhe``: adaptive R and adaptive-gamma H-infinity update (eq. 38-56)."""
    adaptive_r: bool = Field(
        True,
        description="adaptive measurement noise with a fading factor (paper 001 eq. 42-45)")
    hinf: Literal["none", "fixed", "adaptive"] = Field(
        "adaptive",
        description="covariance update: none (Kalman), fixed (H-infinity, fixed gamma) or "
                    "adaptive (eq. 55-56)")


# ----------------------------------------------------------------------------- inputs
def _initial_position(bundle: Bundle, init: Optional[NavState]):
    if init is not None:
        return float(init.lat), float(init.lon), float(init.h)
    pos = bundle.meta.get("initial_position") if isinstance(bundle.meta, dict) else None
    if isinstance(pos, dict) and all(k in pos for k in ("lat_deg", "lon_deg", "h_m")):
        return (float(pos["lat_deg"]) * _DEG, float(pos["lon_deg"]) * _DEG, float(pos["h_m"]))
    if bundle.truth is not None:
        tr = bundle.truth
        if not hasattr(tr, "lat"):          # a truth read in chunks: its first row, read
            r = tr.at(float(tr.t[0]))
            return float(r["lat"]), float(r["lon"]), float(r["h"])
        return float(tr.lat[0]), float(tr.lon[0]), float(tr.h[0])
    raise BadInput(f"bundle {bundle.name!r}: no initial position (give --init, or "
                   "initial_position in meta.yaml)")


def _speed_at_imu(bundle: Bundle, sensor: str):
    """The sensor's speed interpolated to the IMU times (held at the ends, never beyond)."""
    t_imu = bundle.imu.t
    return np.interp(t_imu, *_speed_samples(bundle, sensor, float(t_imu[0]),
                                            float(t_imu[-1])))


def _speed_samples(bundle: Bundle, sensor: str, t_first: float, t_last: float):
    """``(t, v)``: the sensor's times [s] and speeds [m/s] that :func:`_speed_at_imu`
    interpolates, checked to cover the IMU's ``t_first .. t_last`` [s] and to be finite;
    a distance-increment sensor's speeds at their intervals' middles
    (:func:`inmotion.align.velocity_source.speed_times`)."""
    from .velocity_source import speed_times
    try:
        _, sp = bundle.velocity_sensor(sensor)
    except ValueError as exc:
        raise BadInput(str(exc)) from None
    ts = speed_times(sp)
    if ts[0] > t_first + 1.0 or ts[-1] < t_last - 1.0:
        raise BadInput(f"{sensor} covers t = {ts[0]:.3f} .. {ts[-1]:.3f} s but the IMU "
                       f"runs {t_first:.3f} .. {t_last:.3f} s", file=sensor)
    v = sp.speed()
    if not np.all(np.isfinite(v)):
        i = int(np.flatnonzero(~np.isfinite(v))[0])
        raise BadInput(f"{sensor} speed is not finite", file=sensor, row=i + 1, time=ts[i])
    return ts, v


# ----------------------------------------------------------------------------- noise presets
#: the states ``noise_preset: matched`` adds where the configuration leaves them None
_MATCHED_STATES = ("estimate_scale", "estimate_accel_bias", "estimate_gyro_drift",
                   "estimate_integrated_noise")


def resolve_noise(config: UsqueConfig, meta, dt_update_s: float) -> tuple:
    """``(config, config_source)``: the configuration with every noise figure and state
    choice made concrete for ``noise_preset`` (module docstring, "Noise presets"), and
    ``{field: origin}`` (``config``, ``meta.imu (simulated)``, ``meta.sensors.<name>``,
    ``preset matched``, ``preset paper``, ``default``).

    ``paper``: the fields as configured; states left None are off.
    ``matched``: states left None are on (``w``, ``dk``, ``nabla``, ``eps``; ``w`` is
    unavailable with ``vectors: obs_vectors``, which keeps the attitude state only); the IMU
    figures the configuration does not set come from ``meta['imu']``
    (:func:`inmotion.align.parked_kf.spec_from_meta`: ``accel_bias_sigma0_ug``,
    ``gyro_drift_sigma0_deg_h``, ``gyro_arw_deg_sqrt_h``, ``accel_vrw_ug_sqrt_hz``), the
    sensor's from ``meta['sensors'][sensor]`` (``meas_noise_m_s`` from ``noise_m_s``, one
    sample's white noise; ``scale_sigma0_ppm`` from ``scale_factor_sigma_ppm``), and the
    attitude's ``process_noise_deg`` is ``ARW sqrt(dt_update)`` (the gyro's angle random walk
    over one update).
    """
    from .parked_kf import spec_from_meta
    set_ = config.model_fields_set
    src = {}
    upd = {}
    preset = config.noise_preset
    for f in _MATCHED_STATES:
        if f in set_ and getattr(config, f) is not None:
            src[f] = "config"
            continue
        on = preset == "matched" and not (config.vectors == "obs_vectors")
        upd[f] = on
        src[f] = f"preset {preset}" + ("" if on or preset == "paper" else " (obs_vectors)")
    if preset == "paper":
        for f in ("process_noise_deg", "meas_noise_m_s"):
            src[f] = "config" if f in set_ else "preset paper (default)"
        return config.model_copy(update=upd), src
    meta = meta if isinstance(meta, dict) else {}
    spec, origin = spec_from_meta(meta)
    imu_map = {"accel_bias_sigma0_ug": "accel_bias_ug",
               "gyro_drift_sigma0_deg_h": "gyro_drift_deg_h",
               "gyro_arw_deg_sqrt_h": "gyro_arw_deg_sqrt_h",
               "accel_vrw_ug_sqrt_hz": "accel_vrw_ug_sqrt_hz"}
    for f, key in imu_map.items():
        if f in set_:
            src[f] = "config"
        elif key in spec:
            upd[f], src[f] = spec[key], origin
        else:
            src[f] = "default"
    sensors = meta.get("sensors") if isinstance(meta.get("sensors"), dict) else {}
    sens = sensors.get(config.sensor) if isinstance(sensors.get(config.sensor), dict) else {}
    s_origin = f"meta.sensors.{config.sensor}"
    for f, key in (("meas_noise_m_s", "noise_m_s"), ("scale_sigma0_ppm", "scale_factor_sigma_ppm")):
        if f in set_:
            src[f] = "config"
        elif sens.get(key) is not None:
            upd[f], src[f] = float(sens[key]), s_origin
        else:
            src[f] = "default"
    if upd.get("meas_noise_m_s", 1.0) < MEAS_FLOOR_M_S:
        upd["meas_noise_m_s"] = MEAS_FLOOR_M_S
        src["meas_noise_m_s"] += f" (below the floor, {MEAS_FLOOR_M_S:g})"
    # the adaptive R's lower bound: the sensor's own white noise (the correlated errors that
    # the paper preset's 0.05 m/s covered are states now)
    if "r_min_m_s" in set_:
        src["r_min_m_s"] = "config"
    elif "meas_noise_m_s" in upd:
        upd["r_min_m_s"] = min(upd["meas_noise_m_s"], config.r_max_m_s)
        src["r_min_m_s"] = "preset matched: meas_noise_m_s"
    else:
        src["r_min_m_s"] = "default"
    # a state whose spec is zero has nothing to estimate (and a zero prior the sigma points
    # cannot spread): off, unless the configuration asks for it
    for state, f in (("estimate_scale", "scale_sigma0_ppm"),
                     ("estimate_accel_bias", "accel_bias_sigma0_ug"),
                     ("estimate_gyro_drift", "gyro_drift_sigma0_deg_h")):
        if f not in upd or upd[f] > 0.0:
            continue
        if upd.get(state):
            upd[state] = False
            src[state] = f"preset matched: off ({f} = 0 in {src[f]})"
        elif getattr(config, state):          # asked for: keep the configured prior
            del upd[f]
            src[f] = f"default ({src[f]} gives 0)"
    from .meta_spec import _constraint_violation_sigmas, markov_sample_white_equivalent_sigma
    for f, of_gm, what in (
            ("constraint_noise_m_s", markov_sample_white_equivalent_sigma,
             "white equivalent of its samples at the update interval"),
            ("constraint_start_m_s", lambda sig, tau, T: sig, "its 1-sigma")):
        if f in set_:
            src[f] = "config"
            continue
        cv = _constraint_violation_sigmas(meta, of_gm, dt_update_s)
        if cv is not None:
            upd[f] = (float(cv[0]), float(cv[1]))
            src[f] = f"meta.vehicle.constraint_violation ({what})"
        else:
            src[f] = "none (no meta.vehicle.constraint_violation)"
    if "k0" in set_:
        src["k0"] = "config"
    else:            # memory ~ dt (1 + k0)^2 (module docstring, "Gamma for the matched noise")
        upd["k0"] = max(np.sqrt(config.hinf_memory_s / dt_update_s) - 1.0, 1.0)
        src["k0"] = "preset matched: sqrt(hinf_memory_s / dt) - 1"
    if "process_noise_deg" in set_:
        src["process_noise_deg"] = "config"
    else:
        arw = upd.get("gyro_arw_deg_sqrt_h", config.gyro_arw_deg_sqrt_h)
        upd["process_noise_deg"] = arw / 60.0 * np.sqrt(dt_update_s)
        src["process_noise_deg"] = "preset matched: ARW sqrt(dt) (ARW from " + \
            src["gyro_arw_deg_sqrt_h"] + ")"
    return config.model_copy(update=upd), src


# ----------------------------------------------------------------------------- the filter
class _Filter:
    """State, covariance and the cycle of the module docstring (one instance per run)."""

    def __init__(self, cfg: UsqueConfig):
        self.cfg = cfg
        self.extra = [name for name, on in (("dk", cfg.estimate_scale),
                                            ("nabla", cfg.estimate_accel_bias),
                                            ("eps", cfg.estimate_gyro_drift),
                                            ("dv0", cfg.estimate_initial_speed_error),
                                            ("w", cfg.estimate_integrated_noise)) if on]
        self.layout = Layout([ATT] + [_EXTRA_BLOCKS[name] if name in _EXTRA_BLOCKS
                                      else block(name) for name in self.extra])
        self.att = self.layout["dR"]
        self.a = cfg.grp_a
        self.f = 2.0 * (cfg.grp_a + 1.0) if cfg.grp_f is None else cfg.grp_f
        self.scheme = ScaledSigmaPoints(self.layout.n, cfg.ut_sigma, cfg.ut_kappa, cfg.ut_zeta)
        p0 = {"dR": (np.asarray(cfg.sigma0_deg) * _DEG) ** 2}
        q = {"dR": (cfg.process_noise_deg * _DEG) ** 2}
        p0["dk"] = (cfg.scale_sigma0_ppm * 1e-6) ** 2
        p0["nabla"] = (cfg.accel_bias_sigma0_ug * 1e-6 * _G0) ** 2
        p0["eps"] = (cfg.gyro_drift_sigma0_deg_h * _DEG / 3600.0) ** 2
        p0["dv0"] = cfg.initial_speed_sigma0_m_s ** 2
        # w(0): the error of the sample taken as v^b(0) along b(0)'s forward axis = i's y
        # (without a dv0 state), and a floor on the other axes (module docstring)
        # and (issue 15, session 25) the vehicle's lateral and vertical velocity at the start,
        # which the sample taken as v^b(0) = [0, v, 0] leaves out of every measurement
        lat0, vert0 = cfg.constraint_start_m_s or (0.0, 0.0)
        p0["w"] = np.array([max(W0_FLOOR_M_S, lat0), 0.0 if cfg.estimate_initial_speed_error
                            else cfg.meas_noise_m_s, max(W0_FLOOR_M_S, vert0)]) ** 2
        p0["w"][1] = max(p0["w"][1], W0_FLOOR_M_S ** 2)
        p0 = {k: v for k, v in p0.items() if k in self.layout}
        self.P = self.layout.diag(p0)
        self.Q = self.layout.diag(q)
        self.x = self.layout.zeros()
        self.q = np.array([1.0, 0.0, 0.0, 0.0])      # C_{n(0)}^i, the paper's start
        self.R_min = np.full(3, cfg.r_min_m_s ** 2)
        self.R_max = np.full(3, cfg.r_max_m_s ** 2)
        self.R = np.full(3, cfg.meas_noise_m_s ** 2)
        cv = cfg.constraint_noise_m_s
        self.cv2 = np.zeros(2) if cv is None else np.asarray(cv, float) ** 2
        if cfg.adaptive_r:          # the adaptive R lives within its bounds from the start
            self.R = np.clip(self.R, self.R_min, self.R_max)
        self.eta = 1.0
        self.gamma = np.inf
        # H-infinity bounds the attitude error only (eq. 46 with S = L x, L selecting dR)
        self.hinf_weights = np.zeros(self.layout.n)
        self.hinf_weights[self.att] = 1.0
        self.floor_hits = 0
        self.nis_sum, self.updates = 0.0, 0        # the updates' NIS (3 dof each) and count
        self.dt_update_s = 1.0 / cfg.update_rate_hz    # set by run() from the IMU rate
        # integrated-noise state w: its index and the noise densities (rad^2/s, (m/s)^2/s)
        self.i_w = self.layout["w"].start if "w" in self.layout else -1
        self.arw2 = (cfg.gyro_arw_deg_sqrt_h * _DEG / 60.0) ** 2
        self.vrw2 = (cfg.accel_vrw_ug_sqrt_hz * 1e-6 * _G0) ** 2

    def process_noise(self, acc):
        """``Q`` of one update: the configured one, with ``w``'s block and its coupling to the
        attitude (:func:`inmotion.align.usque_model.add_integrated_noise`) when ``w`` is on."""
        if self.i_w < 0:
            return self.Q
        return model.add_integrated_noise(self.Q, acc, self.i_w, self.arw2 * self.dt_update_s,
                                          self.vrw2 * self.dt_update_s)

    def gamma_fixed(self):
        """The fixed gamma of one update [rad]: ``gamma_c / sqrt(dt_update)`` (module docstring)."""
        return self.cfg.gamma_deg_sqrt_s * _DEG / np.sqrt(self.dt_update_s)

    # manifold operations of the attitude block
    def _quats(self, chi, q_ref):
        """Sigma-point quaternions ``delta_q(chi_dR) (x) q_ref`` (eq. 28-29)."""
        dq = rotations.quat_from_grp(chi[:, self.att], self.a, self.f)
        return rotations.quat_multiply(dq, q_ref)

    def _grp_about(self, chi_q, q_ref):
        """GRP of ``chi_q (x) q_ref^-1`` (eq. 30 and 20)."""
        dq = rotations.quat_multiply(chi_q, rotations.quat_conjugate(q_ref))
        return rotations.grp_from_quat(dq, self.a, self.f)

    def predict(self, dq_n, Q=None):
        """Time update through eq. 9 (eq. 24-33); ``Q`` None: the configured one."""
        Wm, Wc = self.scheme.Wm, self.scheme.Wc
        chi = self.scheme.points(self.x, self.P)
        chi_q = model.propagate(self._quats(chi, self.q), dq_n)
        q_bar = quat_average(chi_q, Wm)
        chi = chi.copy()
        chi[:, self.att] = self._grp_about(chi_q, q_bar)
        x = Wm @ chi
        dev = chi - x
        self.P = (dev * Wc[:, None]).T @ dev + (self.Q if Q is None else Q)
        # fold the mean attitude error into the reference quaternion, reset it
        self.q = rotations.quat_normalize(rotations.quat_multiply(
            rotations.quat_from_grp(x[self.att], self.a, self.f), q_bar))
        x[self.att] = 0.0
        self.x = x

    def update(self, obs):
        """Measurement update (eq. 34-38, 42-45, 50-59)."""
        cfg = self.cfg
        Wm, Wc = self.scheme.Wm, self.scheme.Wc
        chi = self.scheme.points(self.x, self.P)
        chi_q = self._quats(chi, self.q)
        S = model.sensitivity(obs, self.extra)
        Z = model.predict_measurement(chi_q, chi[:, self.att.stop:], S, obs)
        Y = Wm @ Z
        dZ = Z - Y
        dX = chi - self.x
        Py0 = (dZ * Wc[:, None]).T @ dZ
        Pxy = (dX * Wc[:, None]).T @ dZ
        e = obs["y"] - Y
        if cfg.adaptive_r:
            self.R, self.eta = adapt_noise(self.R, self.eta, e, np.diag(Py0) + self.R,
                                           cfg.fading_factor, self.R_min, self.R_max)
        R = np.diag(self.R)
        if self.cv2.any():          # the vehicle's lateral / vertical motion (the kernel's)
            C_ib = rotations.dcm_from_quat(obs["q_ib"])
            R = R + (C_ib * np.array([self.cv2[0], 0.0, self.cv2[1]])) @ C_ib.T
        Py = Py0 + R
        K = np.linalg.solve(Py, Pxy.T).T
        self.nis_sum += float(e @ np.linalg.solve(Py, e))
        self.updates += 1
        x = self.x + K @ e
        self.P = self._covariance(Pxy, Py, R, e)
        q_star = quat_average(chi_q, Wm)
        self.q = rotations.quat_normalize(rotations.quat_multiply(
            rotations.quat_from_grp(x[self.att], self.a, self.f), q_star))
        x[self.att] = 0.0
        self.x = x
        return e

    def _covariance(self, Pxy, Py, R, e):
        """Kalman, fixed-gamma or adaptive-gamma covariance update (eq. 51-56).

        ``rho = hinf_margin``: an H-infinity step needs ``gamma >= rho gamma_a``. Fixed gamma
        below that falls back to the Kalman step (counted in ``floor_hits``); the adaptive
        gamma is clamped up to it, like the paper's ``gamma_min`` (eq. 55). Then
        ``P+^-1 >= (1 - 1/rho^2) M``: one step inflates ``P`` at most ``1 / (1 - 1/rho^2)``
        times, and ``gamma_max`` hands large covariances back to the Kalman update.
        """
        cfg, P = self.cfg, self.P
        self.gamma = np.inf
        P_kf = hinf.kalman_covariance(P, Pxy, Py)
        if cfg.hinf == "none":
            return P_kf
        g_a = hinf.floor_from_kalman(P_kf, self.hinf_weights)
        if cfg.hinf == "fixed":
            gamma = self.gamma_fixed()
            if gamma < cfg.hinf_margin * g_a:
                self.floor_hits += 1
                return P_kf
            self.gamma = gamma
            return hinf.hinf_from_kalman(P_kf, gamma, self.hinf_weights)
        gamma = hinf.adaptive_gamma(g_a, Py, e, cfg.k0, cfg.gamma_min_deg * _DEG)
        if gamma < cfg.hinf_margin * g_a:
            gamma = cfg.hinf_margin * g_a
            self.floor_hits += 1
        self.gamma = gamma
        if gamma > cfg.gamma_max_deg * _DEG:          # eq. 56: Kalman above gamma_max
            return P_kf
        return hinf.hinf_from_kalman(P_kf, gamma, self.hinf_weights)


def run(bundle: Bundle, config: UsqueConfig, init: Optional[NavState] = None,
        progress: Optional[Callable[[float], None]] = None, *, method: str = "usque",
        engine: str = "numba") -> Solution:
    """Run the unscented quaternion alignment over the whole bundle.

    Parameters
    ----------
    bundle : Bundle
        IMU and a forward-velocity sensor (``config.sensor``).
    config : UsqueConfig (or a subclass)
    init : NavState or None
        Only its position is used (the attitude starts at the paper's ``[1 0 0 0]``).
    progress : callable(fraction) or None
    method : str
        Name echoed in ``info``.
    engine : {"numba", "numpy"}
        ``numba``: the compiled cycle of :mod:`inmotion.align.usque_kernel` (fast);
        ``numpy``: the readable reference cycle of :class:`_Filter` (same numbers, ~30x slower).

    Returns
    -------
    Solution at the update epochs (the first row is the start, before any update).
    """
    t_start = time.perf_counter()
    config, auto = _resolve_sensor(config, bundle)
    if config.vectors == "obs_vectors":
        return _run_obs_vectors(bundle, config, init, method, t_start)
    if engine == "numpy":
        # the window in memory (a bundle read in chunks: load_window reads only its rows)
        bundle = bundle.load_window()
    imu = bundle.imu
    t_imu = imu.t               # (a bundle read in chunks: read from the file, not kept)
    n_rows = len(t_imu)
    if n_rows < 3:
        raise BadInput(f"bundle {bundle.name!r}: too few IMU rows ({n_rows}) to align")
    t_first = float(t_imu[0])
    sp_t, sp_v = _speed_samples(bundle, config.sensor, t_first, float(t_imu[-1]))
    dt = float(np.median(np.diff(t_imu)))
    del t_imu
    speed_first = float(np.interp(t_first, sp_t, sp_v))
    lat, lon, h = _initial_position(bundle, init)
    stride = max(1, int(round(1.0 / (config.update_rate_hz * dt))))
    config, cfg_source = resolve_noise(config, bundle.meta, stride * dt)
    flt = _Filter(config)
    flt.dt_update_s = stride * dt
    e_s, lever, installation = _installation(bundle.meta, config.sensor)
    acc = model.new_accumulator(lat, lon, h, speed_first, e_s, lever)
    n_epochs = (n_rows - 1) // stride        # updates at rows stride, 2 stride, ...
    out_every = (1 if config.output_interval_s is None
                 else max(1, int(round(config.output_interval_s / (stride * dt)))))
    rows_out = _output_rows(n_epochs, out_every)
    out = _Outputs(len(rows_out) + 1, flt.layout)
    out.record(0, flt, model.observation(acc), acc)
    t_out, speed_out = np.empty(len(rows_out) + 1), np.empty(len(rows_out) + 1)
    t_out[0], speed_out[0] = t_first, speed_first
    if engine == "numba":
        flt.floor_hits = _run_compiled(flt, acc, bundle, t_first, (sp_t, sp_v), stride,
                                       n_epochs, out_every, out, t_out, speed_out, progress)
    elif engine == "numpy":
        speed = np.interp(imu.t, sp_t, sp_v)
        epochs = np.arange(stride, n_rows, stride)
        _run_reference(flt, acc, imu, speed, epochs, out, progress, out_every)
        t_out[1:], speed_out[1:] = imu.t[epochs[rows_out - 1]], speed[epochs[rows_out - 1]]
    else:
        raise ValueError(f"engine must be 'numba' or 'numpy', got {engine!r}")
    if progress is not None:
        progress(1.0)
    info = {"method": method, "config": config.model_dump(), "sensor": config.sensor,
            "timing_s": time.perf_counter() - t_start, "update_stride_rows": stride,
            "final_R_m_s": out.R[-1].tolist(), "hinf_floor_hits": int(flt.floor_hits),
            "nis": _nis(flt),
            "start_attitude": "q = [1 0 0 0] (C_b^n = I), the paper's start",
            "noise_preset": config.noise_preset, "config_source": cfg_source,
            "installation": installation}
    sol = out.solution(t_out, speed_out, flt, info)
    _start_check(sol, flt.q, acc[model.ACC.Q_N0N:model.ACC.Q_N0N + 4], config)
    return _within_envelope(sol, bundle.meta, lat)


#: how far (in its prior 1-sigma, per axis) the estimate of the start attitude may end from
#: the paper's start before :func:`_start_check` warns
START_PRIOR_SIGMAS = 3.0


def _start_check(sol: Solution, q_in, q_n0n, config) -> None:
    """Whether the start lay within its prior (issue 15, session 25). The filter starts from
    the paper's ``C_{n(0)}^i = I`` with the 1-sigma ``sigma0_deg``; at the end its estimate of
    ``C_{n(0)}^i = C_{n(t)}^i C_{n(0)}^{n(t)}`` (``q_in`` the final ``C_{n(t)}^i``, ``q_n0n``
    the accumulator's ``C_{n(t)}^{n(0)}``) says where the start really was. Beyond
    :data:`START_PRIOR_SIGMAS` times the prior on an axis, the start was a draw the prior
    did not allow, the filter's first updates were linearised far from the truth, and its
    sigma has been measured not to cover its error: paper 003's drive (heading 60 deg, the
    paper's 12 deg prior; 120 s, seeds 3-6, the installation's errors zeroed) heading 2-83
    arcmin off at a 4.1 arcmin sigma, the same drive turned to a heading of 0 deg 0.1-1.9
    arcmin at 2.4 (``info['start_check']``, a warning)."""
    from ..core.rotations import quat_conjugate, quat_multiply, rotvec_from_quat
    q0 = quat_multiply(np.asarray(q_in, float), quat_conjugate(np.asarray(q_n0n, float)))
    moved = np.degrees(rotvec_from_quat(q0))
    ratio = np.abs(moved) / np.maximum(np.asarray(config.sigma0_deg, float), 1e-12)
    sol.info["start_check"] = {"start_moved_deg": moved.tolist(),
                               "in_prior_sigmas": ratio.tolist(),
                               "limit_sigmas": START_PRIOR_SIGMAS}
    if np.max(ratio) > START_PRIOR_SIGMAS:
        k = int(np.argmax(ratio))
        sol.info["warnings"] = [*(sol.info.get("warnings") or []), (
            f"the start lay outside its prior: the estimate of the start attitude ended "
            f"{moved[k]:.1f} deg from the paper's q = [1 0 0 0] about {'xyz'[k]}, "
            f"{ratio[k]:.1f} times sigma0_deg ({config.sigma0_deg[k]:g} deg); linearised far "
            "from the truth, the sigma is not to be trusted (measured: heading errors up to "
            "20 times it); widen sigma0_deg to cover the start")]


def _within_envelope(sol: Solution, meta, lat: float) -> Solution:
    """What the IMU allows, as for the coarse alignments (issue 15: a method outside its
    envelope says so): ``info['envelope']`` from ``meta['imu']``'s drift and bias over the run
    (:func:`inmotion.align.attitude_determination.envelope_from_meta`); where the gyros cannot
    resolve the heading by the Earth rate (a MEMS or phone IMU) a warning, and the reported
    heading 1-sigma kept at least that of a heading known only to lie in +-180 deg and the
    level 1-sigma at least ``bias / g`` (:func:`inmotion.align.multiplex.floor_attitude_sigma`).
    Measured (session 18) on the comma2k19 log (phone IMU, assumed 150 deg/h) from the
    paper's start: usque ended 691 arcmin off in heading at a 230 arcmin sigma (attitude NEES
    over the run 3.1e4), with no warning. Inside the envelope (a navigation-grade IMU, the
    papers' drives) nothing changes."""
    from .attitude_determination import envelope_from_meta, envelope_warning
    from .multiplex import floor_attitude_sigma
    if len(sol.t) < 2:
        return sol
    _unknown_mounting(sol, meta)
    env = envelope_from_meta(meta, lat, float(sol.t[-1] - sol.t[0]))
    if env is None:
        return sol
    sol.info["envelope"] = env
    warning = envelope_warning(env, lat)
    if warning is not None:
        floor_attitude_sigma(sol, env)
        sol.info["warnings"] = [*(sol.info.get("warnings") or []), warning]
    return sol


def _installation(meta, sensor: str) -> tuple:
    """``(e_s, lever_b, info)`` of the speed sensor's installation as ``meta.yaml`` states it
    (issue 15, session 25): ``e_s = C_v^b [0, 1, 0]`` the direction in b along which the
    vehicle moves, from the IMU's mounting ``vehicle_mounting_arcmin``
    (:func:`inmotion.core.rotations.mounting_dcm`), and the sensor's lever arm in b
    ``lever_arms_m[sensor]`` (its reading less ``e_s . (omega x l)``); b's forward axis and no
    lever arm where ``meta`` gives none. Paper 001 takes its LDV as calibrated in advance;
    what a calibration gives is this. The beam's own misalignment acts to second order
    (:mod:`inmotion.sim.sensors`) and is not taken. Measured on paper 003's drive (10 / 15
    arcmin mounting, the LDV 1.2 m ahead; 120 s, heading 0 deg, seeds 3-8): without it the
    level ended 1-2 arcmin off at a 0.2 arcmin sigma and the heading 54-58 at 2.1."""
    from .meta_spec import stated_installation
    A, lever = stated_installation(meta, sensor)
    e_s = np.array([0.0, 1.0, 0.0])
    if A is not None and np.any(A != 0.0):
        e_s = rotations.mounting_dcm(A * _DEG / 60.0) @ e_s
    info = {"mounting_arcmin": None if A is None else A.tolist(),
            "lever_arm_m": None if lever is None else lever.tolist()}
    return e_s, np.zeros(3) if lever is None else lever, info


def _unknown_mounting(sol: Solution, meta) -> None:
    """Where ``meta.yaml`` does not give the IMU's mounting in the vehicle
    (``vehicle_mounting_arcmin``): a warning, and the attitude 1-sigma kept at least the
    unknown-mounting prior (:data:`inmotion.align.meta_spec.UNKNOWN_MOUNTING_SIGMA_ARCMIN`) on
    every axis. The paper's model (paper 001 sec. 2) takes the sensor's speed along the IMU's
    forward axis, so the mounting's pitch and yaw go one to one into the attitude it finds,
    and nothing in the filter can see them (issue 15, session 19: comma2k19, the phone
    pitched 3.8 deg in the car, usque ended 405 arcmin off in the East tilt at a 34 arcmin
    sigma). On the papers' simulated bundles the mounting is given (zero for paper 001's) and
    nothing changes. A mounting that is given is applied (:func:`_installation`, session 25)."""
    from .meta_spec import note_unknown_mounting
    note_unknown_mounting(
        sol, sol.info.get("method", "the USQUE family"), meta,
        ignored="takes the sensor's speed along the IMU's forward axis",
        advice="align the IMU with the vehicle, or use a method with mounting states (od-kf, "
               "dr-kf, od-velocity-kf)")


def _nis(flt) -> dict:
    """``info['nis']``: the updates' NIS under the sensor's name (3 degrees of freedom each:
    the vector observation of eq. 34; :func:`inmotion.estimation.chi2.nis_summary`), issue 15.
    With ``adaptive_r`` the R is the adapted one, with an H-infinity update ``Py`` is still
    the Kalman form of eq. 37 taken with the (H-infinity) prediction's covariance."""
    from ..estimation.chi2 import nis_summary
    return {flt.cfg.sensor: nis_summary(flt.nis_sum, 3 * flt.updates, flt.updates)}


def _output_rows(n_epochs: int, out_every: int) -> np.ndarray:
    """The update epochs (1-based) written out: every ``out_every``-th and the last."""
    e = np.arange(out_every, n_epochs + 1, out_every)
    if n_epochs and (len(e) == 0 or e[-1] != n_epochs):
        e = np.append(e, n_epochs)
    return e


def _slots(first: int, n: int, n_epochs: int, out_every: int) -> np.ndarray:
    """Output row of the epochs ``first + 1 .. first + n`` (1-based; -1: not written):
    epoch ``J`` on the grid goes to row ``J // out_every``, the last epoch to the last row."""
    J = np.arange(first + 1, first + n + 1)
    slot = np.where(J % out_every == 0, J // out_every, -1)
    if n and J[-1] == n_epochs and n_epochs % out_every:
        slot[-1] = n_epochs // out_every + 1
    return slot.astype(np.int64)


def _run_obs_vectors(bundle, config, init, method, t_start):
    """The filter on the coarse-alignment module's vectors (``config.vectors="obs_vectors"``),
    block by block: :func:`inmotion.align.obs_vectors.vector_rows` yields each block's vector
    rows (every interval's), the filter takes them and is carried to the next block, and only
    the output rows are kept (``output_interval_s``); a bundle read in chunks gives the
    window's rows as it reads them (:func:`inmotion.align.attitude_determination.
    window_blocks`). The same operations as over all rows at once."""
    from ..align.attitude_determination import window_blocks
    from . import obs_vectors as ov
    from . import usque_kernel as kernel
    from . import velocity_source as vs
    t_imu = bundle.imu.t        # (a bundle read in chunks: read from the file, not kept)
    dt = float(np.median(np.diff(t_imu)))
    config, cfg_source = resolve_noise(config, bundle.meta, 2.0 * dt)
    flt = _Filter(config)
    flt.dt_update_s = 2.0 * dt                      # two-sample intervals
    if flt.extra:
        raise BadInput("vectors=obs_vectors supports the attitude state only; "
                       f"drop {', '.join(flt.extra)} or use vectors=own")
    n_rows = len(t_imu)
    if n_rows < 3:
        raise BadInput(f"bundle {bundle.name!r}: too few IMU rows ({n_rows}) to align")
    t_first = float(t_imu[0])
    samples = _speed_samples(bundle, config.sensor, t_first, float(t_imu[-1]))
    del t_imu
    lat, lon, h = _initial_position(bundle, init)
    _, data = bundle.velocity_sensor(config.sensor)
    speed0 = vs.initial_speed(config.sensor, data, t_first, config.v0_fit_s)
    n_epochs = n_rows // 2                          # rows 1.. two at a time
    out_every = (1 if config.output_interval_s is None
                 else max(1, int(round(config.output_interval_s / flt.dt_update_s))))
    out = _Outputs(len(_output_rows(n_epochs, out_every)) + 1, flt.layout)
    t_out = np.empty(len(out.gamma))
    out.q_in[0], out.R[0], out.gamma[0], out.x[0] = flt.q, np.sqrt(flt.R), np.inf, flt.x
    out.set_P(0, flt.P)
    mode = {"none": kernel.HINF_NONE, "fixed": kernel.HINF_FIXED,
            "adaptive": kernel.HINF_ADAPTIVE}[config.hinf]
    x, P, q, R, eta = flt.x.copy(), flt.P.copy(), flt.q.copy(), flt.R.copy(), flt.eta
    hits, done, prev = 0, 0, None
    lla = [ov.OUT_LAT, ov.OUT_LON, ov.OUT_H]
    for rows, _ in ov.vector_rows(window_blocks(bundle, t_first, samples), speed0, lat, lon, h,
                                  model=ov.MODEL_VB_EARTH, out_every=1):
        if prev is None:                            # the start
            out.q_ib[0], out.lla[0], t_out[0] = rows[0, ov.OUT_QB], rows[0, lla], rows[0, 0]
            prev = rows[-1:]
            continue
        if not len(rows):
            continue
        both = np.concatenate([prev, rows])         # the previous epoch leads the block
        # paper 001: alpha = C_{n(t)}^i beta_001 with beta_001 = C_{n(0)}^{n(t)} beta
        q_n0n = np.ascontiguousarray(both[:, ov.OUT_QN])
        beta_n = np.einsum("kji,kj->ki", rotations.dcm_from_quat(q_n0n), both[:, ov.OUT_BETA])
        slot = _slots(done, len(rows), n_epochs, out_every)
        rel, P_out, q_in, _, _, R_out, gamma_out, x_out = out.block(slot)
        h_b, nis_b, x, P, q, R, eta = kernel.run_vector_epochs(
            np.ascontiguousarray(both[:, ov.OUT_ALPHA]), np.ascontiguousarray(beta_n), q_n0n,
            rel, x, P, q, flt.Q, flt.scheme.Wm, flt.scheme.Wc, flt.scheme.n + flt.scheme.lam,
            flt.a, flt.f, R, eta, config.adaptive_r, config.fading_factor, flt.R_min,
            flt.R_max, mode, flt.gamma_fixed(), config.k0, config.gamma_min_deg * _DEG,
            config.gamma_max_deg * _DEG, config.hinf_margin, flt.hinf_weights, q_in,
            P_out, R_out, gamma_out, x_out)
        out.commit()
        hits += h_b
        flt.nis_sum += nis_b
        flt.updates += len(rows)
        w = slot >= 0
        out.q_ib[slot[w]] = rows[w][:, ov.OUT_QB]
        out.lla[slot[w]] = rows[w][:, lla]
        t_out[slot[w]] = rows[w][:, ov.OUT_T]
        done += len(rows)
        prev = rows[-1:]
    info = {"method": method, "config": config.model_dump(), "sensor": config.sensor,
            "timing_s": time.perf_counter() - t_start, "update_stride_rows": 2,
            "final_R_m_s": out.R[-1].tolist(), "hinf_floor_hits": int(hits),
            "nis": _nis(flt),
            "vectors": "inmotion.align.obs_vectors (MODEL_VB_EARTH)",
            "start_attitude": "q = [1 0 0 0] (C_b^n = I), the paper's start",
            "noise_preset": config.noise_preset, "config_source": cfg_source}
    # the speed at the vectors' times (IMU times: the values interpolated at the IMU rows)
    return _within_envelope(out.solution(t_out, np.interp(t_out, *samples), flt, info),
                            bundle.meta, lat)


def _run_reference(flt, acc, imu, speed, epochs, out, progress, out_every=1):
    """The filter cycle in readable numpy (module docstring steps 1-5)."""
    slot = _slots(0, len(epochs), len(epochs), out_every)
    dt_rows = np.diff(imu.t)
    q_n0n_prev = model.observation(acc)["q_n0n"]
    k_prev = 0
    for j, k in enumerate(epochs, start=1):
        q_bn = model.attitude_bn(flt.q, acc[model.ACC.Q_IB:model.ACC.Q_IB + 4])
        model.accumulate(acc, imu.dtheta[k_prev + 1:k + 1], imu.dvel[k_prev + 1:k + 1],
                         dt_rows[k_prev:k], speed[k_prev + 1:k + 1], q_bn)
        obs = model.observation(acc)
        flt.predict(model.nav_increment(q_n0n_prev, obs["q_n0n"]), flt.process_noise(acc))
        flt.update(obs)
        if slot[j - 1] >= 0:
            out.record(slot[j - 1], flt, obs, acc)
        q_n0n_prev = obs["q_n0n"]
        k_prev = k
        if progress is not None and j % 1000 == 0:
            progress(j / len(epochs))


#: IMU rows per block the compiled cycle takes at a time (rounded to whole update strides)
BLOCK_ROWS = 16384


def _run_compiled(flt, acc, bundle, t_first, samples, stride, n_epochs, out_every, out,
                  t_out, speed_out, progress):
    """The same cycle in :func:`inmotion.align.usque_kernel.run_epochs`, block by block: the
    IMU rows after the first (a bundle read in chunks: only the window's, read as they are
    taken, :meth:`~inmotion.io.bundle_stream.BundleStream.imu_rows_in_window`) regrouped into
    blocks of whole update strides, each led by the row of the previous block's last epoch,
    the filter carried from block to block; the speed interpolated to each block's times
    (elementwise: the whole window's values). Writes the output rows of ``out``, ``t_out``,
    ``speed_out``; returns the H-infinity floor hits."""
    from ..core.bundle import regroup
    from . import usque_kernel as kernel
    cfg = flt.cfg
    mode = {"none": kernel.HINF_NONE, "fixed": kernel.HINF_FIXED,
            "adaptive": kernel.HINF_ADAPTIVE}[cfg.hinf]
    after = getattr(bundle, "imu_rows_in_window", None)
    if after is None:
        imu = bundle.imu
        pieces = [(imu.t[1:], imu.dtheta[1:], imu.dvel[1:])]
    else:
        _, _, pieces, _ = after(t_first)
    size = stride * max(1, BLOCK_ROWS // stride)
    x, P, q, R, eta = flt.x.copy(), flt.P.copy(), flt.q.copy(), flt.R.copy(), flt.eta
    prev = (np.array([t_first]), np.zeros((1, 3)), np.zeros((1, 3)))
    hits, done = 0, 0
    for blk in regroup(pieces, size):
        m = len(blk[0]) // stride                 # the block's epochs (a last partial
        if m == 0:                                # stride after the last epoch: unused,
            continue                              # but read: the reader's checks end there)
        t, dth, dvl = (np.concatenate([p, b[:m * stride]]) for p, b in zip(prev, blk))
        speed = np.interp(t, *samples)
        epochs = np.arange(stride, m * stride + 1, stride)
        slot = _slots(done, m, n_epochs, out_every)
        rel, P_out, q_in, q_ib, lla, R_out, gamma_out, x_out = out.block(slot)
        h, nis, x, P, q, R, eta = kernel.run_epochs(
            acc, dth, dvl, np.diff(t), speed, epochs, rel, x, P, q, flt.Q, flt.scheme.Wm,
            flt.scheme.Wc, flt.scheme.n + flt.scheme.lam, flt.a, flt.f, R, eta,
            cfg.adaptive_r, cfg.fading_factor, flt.R_min, flt.R_max, mode, flt.gamma_fixed(),
            cfg.k0, cfg.gamma_min_deg * _DEG, cfg.gamma_max_deg * _DEG, cfg.hinf_margin,
            flt.hinf_weights, "dk" in flt.extra, "nabla" in flt.extra, "eps" in flt.extra,
            "dv0" in flt.extra, "w" in flt.extra, flt.arw2 * flt.dt_update_s,
            flt.vrw2 * flt.dt_update_s, q_in, q_ib, lla, P_out, R_out, gamma_out, x_out,
            flt.cv2)
        out.commit()
        hits += h
        flt.nis_sum += nis
        flt.updates += m
        w = slot >= 0
        t_out[slot[w]], speed_out[slot[w]] = t[epochs[w]], speed[epochs[w]]
        done += m
        prev = (t[-1:], dth[-1:], dvl[-1:])
        if progress is not None:
            progress(done / max(n_epochs, 1))
    flt.x, flt.P, flt.q, flt.R, flt.eta = x, P, q, R, eta
    return hits


def _positive_definite(P):
    """True if every covariance of ``P`` (N, n, n) is positive definite (one batched Cholesky
    of the correlation matrices, so the states' different units do not matter)."""
    d = np.sqrt(np.abs(np.diagonal(P, axis1=-2, axis2=-1)))
    if not (np.all(np.isfinite(P)) and np.all(d > 0)):
        return False
    try:
        np.linalg.cholesky(P / d[:, :, None] / d[:, None, :])
    except np.linalg.LinAlgError:
        return False
    return True


class _Outputs:
    """Preallocated output arrays (memory grows only with the output). Of each output row's
    covariance only the attitude block is kept (``P_att``, the misalignment sigma), and
    whether every one so far is positive definite (``pd``, :func:`_positive_definite`, the
    summary's ``P_positive_definite``): the full covariances of a block's rows are written
    to a buffer the size of the block (:meth:`block`) and checked when it is done
    (:meth:`commit`), the same verdict as checking all rows at once (the check is row by row),
    without holding ``n x n`` numbers per output row (measured, ``align --method usque
    --start 70 --set update_rate_hz=1`` on bench_memory's 4 h drive: 12 states, 14332 rows,
    15.7 MiB no longer held; peak RSS 4 h / 1 h 1.150 -> 1.099)."""

    def __init__(self, n, layout):
        self.q_in = np.empty((n, 4))
        self.q_ib = np.empty((n, 4))
        self.lla = np.empty((n, 3))
        self.att = layout["dR"]
        self.P_att = np.empty((n, 3, 3))
        self.pd = True
        self.R = np.empty((n, 3))
        self.gamma = np.empty(n)
        self.x = np.empty((n, layout.n))
        self._P = np.empty((1, layout.n, layout.n))     # the block's covariances
        self._rows = (0, 0)

    def set_P(self, j, P):
        """Output row ``j``'s covariance ``P`` (kept: its attitude block, checked)."""
        self.P_att[j] = P[self.att, self.att]
        self.pd = self.pd and _positive_definite(P[None])

    def block(self, slot):
        """For a kernel call writing epoch ``i`` to output row ``slot[i]`` (-1: none):
        ``(rel, P, q_in, q_ib, lla, R, gamma, x)``, the rows relative to the block's first
        output row, the covariance buffer of the block's rows and the output arrays from that
        row on (views: the kernel's writes land in them). :meth:`commit` when done."""
        w = np.flatnonzero(slot >= 0)
        s0 = int(slot[w[0]]) if len(w) else 0
        k = int(slot[w[-1]]) - s0 + 1 if len(w) else 0
        if len(self._P) < k:
            self._P = np.empty((k, *self._P.shape[1:]))
        self._rows = (s0, k)
        rel = np.where(slot >= 0, slot - s0, -1).astype(np.int64)
        return (rel, self._P, self.q_in[s0:], self.q_ib[s0:], self.lla[s0:], self.R[s0:],
                self.gamma[s0:], self.x[s0:])

    def commit(self):
        """The block's covariances written by the kernel: their attitude blocks kept, checked
        (none left to check once one is not positive definite)."""
        s0, k = self._rows
        P = self._P[:k]
        self.P_att[s0:s0 + k] = P[:, self.att, self.att]
        self.pd = self.pd and (k == 0 or _positive_definite(P))
        self._rows = (0, 0)

    def record(self, j, flt, obs, acc):
        ACC = model.ACC
        self.q_in[j] = flt.q
        self.q_ib[j] = obs["q_ib"]
        self.lla[j] = acc[ACC.LAT], acc[ACC.LON], acc[ACC.H]
        self.set_P(j, flt.P)
        self.R[j] = np.sqrt(flt.R)
        self.gamma[j] = flt.gamma
        self.x[j] = flt.x

    def solution(self, t, speed, flt, info):
        """Vehicle attitude, sensor velocity, DR position and the misalignment sigma."""
        layout, att = flt.layout, flt.att
        q_bn = model.attitude_bn(self.q_in, self.q_ib)
        vel_n = rotations.quat_rotate(q_bn, np.stack([np.zeros_like(speed), speed,
                                                      np.zeros_like(speed)], -1))
        C_ni = np.swapaxes(rotations.dcm_from_quat(self.q_in), -1, -2)
        P_phi = C_ni @ self.P_att @ np.swapaxes(C_ni, -1, -2)
        sig = np.sqrt(np.maximum(np.diagonal(P_phi, axis1=-2, axis2=-1), 0.0))
        info["P_positive_definite"] = bool(self.pd)
        sigma = {"phi_E": sig[:, 0], "phi_N": sig[:, 1], "phi_U": sig[:, 2]}
        states = {"R_x": self.R[:, 0], "R_y": self.R[:, 1], "R_z": self.R[:, 2],
                  "gamma": self.gamma}
        units = {"R_x": StateUnit("m/s"), "R_y": StateUnit("m/s"), "R_z": StateUnit("m/s"),
                 "gamma": StateUnit("deg", 180.0 / np.pi)}
        umap = layout.unit_map()
        for name in layout.names[3:]:
            states[name] = self.x[:, layout.index(name)]
            units[name] = umap[name]
        return Solution.from_arrays(t, self.lla, vel_n, q_bn, sigma=sigma, states=states,
                                    state_units=units, info=info)


def _resolve_sensor(config, bundle):
    """``(config with a concrete sensor, was_auto)``: ``sensor: auto`` becomes the first present
    of ldv, radar, odometer."""
    if config.sensor != "auto":
        return config, False
    for name in ("ldv", "radar", "odometer"):
        if getattr(bundle, name) is not None:
            return config.model_copy(update={"sensor": name}), True
    raise BadInput(f"bundle {bundle.name!r} has no velocity sensor (looked for ldv, radar, "
                   "odometer); the unscented alignments need a forward-velocity sensor")


def run_usque(bundle, config: UsqueConfig, init=None, progress=None) -> Solution:
    """``usque``: unscented quaternion estimator (paper 001 scheme 3)."""
    return run(bundle, config, init, progress, method="usque")


def run_ausque(bundle, config: AusqueConfig, init=None, progress=None) -> Solution:
    """``ausque``: USQUE + adaptive R (paper 001 scheme 4)."""
    return run(bundle, config, init, progress, method="ausque")


def run_usque_hinf(bundle, config: UsqueHinfConfig, init=None, progress=None) -> Solution:
    """``usque-hinf``: USQUE + H-infinity update with fixed gamma (paper 001 scheme 5)."""
    return run(bundle, config, init, progress, method="usque-hinf")


def run_ausquhe(bundle, config: AusquheConfig, init=None, progress=None) -> Solution:
    """``ausquhe``: adaptive R + adaptive-gamma H-infinity USQUE (paper 001 scheme 1)."""
    return run(bundle, config, init, progress, method="ausquhe")
