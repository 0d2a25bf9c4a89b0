"""Feeding a logged drive to the error-state engine: a SINS aided by one forward-velocity
sensor, with or without a dead reckoner beside it.

This is how ``sins-dr`` (paper 002), ``dr-kf`` (paper 000) and ``od-velocity-kf`` run: an
:class:`~inmotion.estimation.engine.ErrorStateFilter` with the measurement plug-ins of the
groups chosen (:data:`GROUPS`), fed in chunks of whole filter epochs through the streaming
API. Per chunk, the velocity sensor is resampled to the IMU rows
(:func:`inmotion.core.deadreckoning.speed_on_epochs`: the DR's distance and speed per row), and
every ``meas_every``-th filter epoch queues one sample of each group at the epoch's end time
(the sensor's speed and the barometric height there as data), so every sample falls due at
the end of its epoch. Only the outputs grow with the log.

=================  ==============================================  ======================
group              measurement                                     needs
=================  ==============================================  ======================
attitude           :class:`~.measurements.SinsDrAttitude`          DR
velocity           :class:`~.measurements.SinsDrVelocity`          DR
sensor_velocity    :class:`~.measurements.ForwardVelocity`         speed
nhc                :class:`~.measurements.Nhc`
position           :class:`~.measurements.SinsDrPosition`          DR
height             :class:`~.measurements.Height`                  baro
=================  ==============================================  ======================

Samples sharing an epoch are applied in the order of that table.
"""
from __future__ import annotations

import numpy as np
from pydantic import BaseModel, Field

from ..core.bundle import SpeedData, regroup
from ..core.deadreckoning import speed_on_epochs
from ..core.solution import NavState
from ..errors import BadInput
from . import error_model as em
from . import measurements as ms
from .engine import ErrorStateFilter
from .layout import Layout
from .smoother import ForwardRecord, smooth_at_outputs

__all__ = ["StopUpdateFields", "imu_point_speed", "check_stops", "dr_gyro_rows", "with_dr_gyro", "GROUPS", "GROUP_SIZES", "VelocityAidedRun", "regroup"]

#: the measurement groups, in the order they are applied within an epoch
GROUPS = ("attitude", "velocity", "sensor_velocity", "nhc", "position", "height",
          "zero_velocity")
#: the groups whose sample reads the velocity sensor: the sensor's speed
#: (``sensor_velocity``), the DR's velocity and position (``velocity``, ``position``; the
#: DR's distance across a sensor gap is interpolated, so a sample there would be made up).
#: They are skipped at epochs inside a gap or outside the sensor's span (issue 15, session
#: 20: on the simulated phone drive with the odometer out for 35 s, seeds 0-2, sins-dr's
#: samples in the gap left its level up to 35 times its sigma and 230 m off at 23 m; skipped,
#: within 3 sigma, ``tests/test_sins_dr.py``)
READS_SPEED = ("velocity", "sensor_velocity", "position")
#: rows per group
GROUP_SIZES = {"attitude": 3, "velocity": 3, "sensor_velocity": 3, "nhc": 2, "position": 3,
               "height": 1, "zero_velocity": 3}
#: IMU rows per chunk handed to the engine (rounded to whole filter epochs)
CHUNK_ROWS = 16384
#: sensor samples whose median period sets the gap threshold (5 periods), as dead_reckon's
GAP_SAMPLES = 10001


def _measurements(use, noise, gates, nhc_mount, second_order=True):
    """The measurement plug-ins of the groups in ``use``, in :data:`GROUPS` order
    (``second_order``: the body-frame velocity rows' second order,
    :mod:`~inmotion.estimation.second_order`)."""
    so = bool(second_order)
    make = {
        "attitude": lambda g: ms.SinsDrAttitude(noise["attitude_rad"], gate=g),
        "velocity": lambda g: ms.SinsDrVelocity(noise["velocity_b_m_s"], second_order=so,
                                                gate=g),
        "sensor_velocity": lambda g: ms.ForwardVelocity(noise["velocity_b_m_s"],
                                                        second_order=so, gate=g),
        "nhc": lambda g: ms.Nhc(noise.get("nhc_m_s", 1.0), mount_terms=nhc_mount,
                                second_order=so, gate=g),
        "position": lambda g: ms.SinsDrPosition(noise["position_m"], gate=g),
        "height": lambda g: ms.Height(noise["height_m"], gate=g),
        "zero_velocity": lambda g: ms.ZeroVelocity(np.full(3, noise.get("zupt_m_s", 0.02)),
                                                   gate=g),
    }
    return [make[g](float(gates.get(g, 0.0))) for g in GROUPS if use.get(g, False)]


def _speed_on_chunk(speed: SpeedData, edges, max_gap: float, sensor: str):
    """:func:`speed_on_epochs` on the sensor samples that cover ``edges[0] .. edges[-1]`` (one
    more on each side, at least two): resampling and validating a chunk costs memory of the
    chunk's size, not the log's. Distance differences inside the window are those of the whole
    log; consecutive windows share their end samples, so every pair of samples is checked, and
    a bad row is reported with its row number in the whole table."""
    ts = speed.t
    if len(ts) < 2:
        raise BadInput(f"need at least 2 samples, got {len(ts)}", file=sensor)
    i0 = max(0, min(int(np.searchsorted(ts, edges[0], side="right")) - 1, len(ts) - 2))
    i1 = min(len(ts), max(int(np.searchsorted(ts, edges[-1], side="left")) + 1, i0 + 1) + 1)
    w = slice(i0, i1)
    window = SpeedData(ts[w], None if speed.v is None else speed.v[w],
                       None if speed.ds is None else speed.ds[w])
    try:
        return speed_on_epochs(window, edges, max_gap=max_gap, what=sensor)
    except BadInput as e:
        raise BadInput(e.what, file=e.file, row=None if e.row is None else e.row + i0,
                       time=e.time) from None


def _dr_reseeds(blind, ends, was_blind: bool, with_dr: bool):
    """``(cuts, last_blind)``: where a chunk's rows are split to put the DR's position back on
    the SINS's (:meth:`~inmotion.estimation.engine.ErrorStateFilter.reseed_dr_position`), and
    whether its last row is blind. ``blind`` marks the chunk's IMU rows without the speed
    sensor (in a gap, or outside its span), ``ends`` the row counts at which its filter epochs
    end, ``was_blind`` the previous chunk's last row. At every return of the speed the cut is
    the last epoch end at or before the first row with the speed back, so the reseed precedes
    every sample that reads it again; the DR's distance over the remaining blind rows (less
    than one epoch) is interpolated. Without a DR (``with_dr`` false), none."""
    if not with_dr or not len(blind):
        return [], bool(blind[-1]) if len(blind) else was_blind
    prev = np.r_[was_blind, blind[:-1]]
    back = np.flatnonzero(prev & ~blind)          # first rows with the speed back
    cuts = []
    for r0 in back:
        k = int(np.searchsorted(ends, r0, side="right")) - 1
        cut = int(ends[k]) if k >= 0 else 0
        if not cuts or cut > cuts[-1]:
            cuts.append(cut)
    return cuts, bool(blind[-1])


def dr_gyro_rows(imu, dtheta_dr, rows):
    """The dead reckoner's own gyro increments on ``rows`` of ``imu``, checked.

    ``dtheta_dr`` is None (the DR turns with the IMU's gyros) or an (N, 3) array [rad], one row
    per IMU row of the bundle: increments of a separate gyro the dead reckoner integrates
    instead (e.g. a vehicle's yaw-rate sensor, or in a simulation study gyros without the
    IMU's drift). :class:`BadInput` names what is wrong."""
    if dtheta_dr is None:
        return None
    d = np.asarray(dtheta_dr, dtype=float)
    if d.shape != imu.dtheta.shape:
        raise BadInput(f"dtheta_dr: expected one row of 3 increments [rad] per IMU row, shape "
                       f"{imu.dtheta.shape}, got {d.shape}")
    idx = np.arange(len(d))[rows]
    bad = ~np.all(np.isfinite(d[idx]), axis=1)
    if bad.any():
        k = int(idx[np.argmax(bad)])
        raise BadInput(f"dtheta_dr: row {k} (t = {imu.t[k]:.3f} s) is not finite")
    return d[idx]


def with_dr_gyro(pieces, dtheta_dr_rows):
    """IMU pieces ``(t, dtheta, dvel)`` with the DR's own gyro rows attached as a fourth
    column (``dtheta_dr_rows``: one row per row of the pieces, in order); the pieces as they
    are when it is None."""
    if dtheta_dr_rows is None:
        return pieces
    out, k = [], 0
    for t, dtheta, dvel in pieces:
        n = len(t)
        out.append((t, dtheta, dvel, dtheta_dr_rows[k:k + n]))
        k += n
    if k != len(dtheta_dr_rows):
        raise BadInput(f"dtheta_dr: {len(dtheta_dr_rows)} rows for {k} IMU rows")
    return out


def imu_point_speed(v, dtheta, dt, forward_b, lever_arm_b):
    """The IMU point's forward speed from a sensor's reading ``v`` [m/s] at the ends of IMU
    rows with gyro increments ``dtheta`` (M, 3) [rad] over ``dt`` (M,) [s].

    The sensor at the lever arm ``l_b`` reads the forward component of its own velocity over
    ground, ``v = u + u_b . (omega_eb_b x l_b)`` (paper 002 eq. 8 with the lever arm; the
    dead reckoner removes the same term, :func:`inmotion.core._kernels.dr_step`), so
    ``u = v - u_b . ((dtheta / dt) x l_b)``. Velocity matching (``od-velocity-kf``) compares
    the SINS velocity of the IMU point with ``u``: uncorrected, a 0.3 m lateral arm in a
    4 deg/s turn reads 0.02 m/s high for the whole turn, a bias twice an LDV's white noise
    that the filter took for a tilt (issue 15: a level error of -0.2 arcmin against a 0.08
    arcmin sigma in 6 of 6 runs). The Earth's rate is left in ``omega``: ``omega_ie |l_b|``
    is 1e-4 m/s for a 1.3 m arm, a hundredth of the noise of any speed sensor."""
    if not np.any(lever_arm_b):
        return v
    w = np.asarray(dtheta, dtype=float) / np.asarray(dt, dtype=float)[:, None]
    return v - np.cross(w, lever_arm_b) @ forward_b


class StopUpdateFields(BaseModel):
    """The configuration fields of zero-velocity updates at stops, shared by every filter
    that takes them (``dr-kf``, ``od-velocity-kf``, ``sins-dr`` and the paper-003 filters);
    :func:`check_stops` checks the windows."""

    stops_s: list[list[float]] = Field(
        default_factory=list,
        description="[start, end] windows [s] in which the vehicle stands still: zero-velocity "
                    "updates at every measurement epoch inside (inmotion process fills them "
                    "from the motion test)")
    zupt_noise_m_s: float = Field(
        0.02, gt=0, description="1-sigma of the zero-velocity update at a stop (sway) [m/s]")


#: zero-velocity update noise [m/s] on a simulated vehicle with no disturbances
#: (:func:`zupt_noise_from_meta`; a measured choice, see there)
ZUPT_STILL_M_S = 5e-3


def calm_simulation(meta) -> bool:
    """A simulated bundle whose ``disturbances`` (vibration, rocking, ...) are all off: its
    vehicle stands exactly still at a stop and keeps its constraint but for the
    ``vehicle.constraint_violation`` it states."""
    if not isinstance(meta, dict) or not meta.get("simulated"):
        return False
    dist = meta.get("disturbances") or {}
    return isinstance(dist, dict) and not any(dist.get(k) for k in dist)


#: the ``config_source`` origin of :func:`zupt_noise_from_meta`'s value
ZUPT_ORIGIN = "meta (simulated, no disturbances: the vehicle stands still)"


def zupt_noise_from_meta(meta) -> dict:
    """``{"zupt_noise_m_s": value}`` of the matched presets (``dr-kf``, ``od-velocity-kf``,
    ``sins-dr``, the paper 003 filters), or ``{}``: on a calm simulated bundle
    (:func:`calm_simulation`) the stopped vehicle has no sway, and the update's noise covers
    only the roll-out at the edges of a detected stop window, :data:`ZUPT_STILL_M_S`;
    elsewhere (real logs, a simulated engine vibration or rocking) the configured sway figure
    (0.02 m/s) stays.

    Why (issue 15, measured on ``tests/test_process.py``'s stop-and-go radar drive, seeds
    0-2, ``inmotion process`` with the methods' matched presets): with the 0.02 m/s sway figure
    on such a vehicle, ``dr-kf``'s velocity sigma at the stop is 0.011 m/s (the radar's own
    0.05 m/s at 2 Hz), so each update takes about a quarter of the error (gain ``P / (P +
    R)``) and an error the stop begins with lasts seconds: the largest velocity error at the
    stops was 0.67 of the run's without the updates (seed 1, its velocity 0.04 m/s off along
    the track as the stop began; 0.31, 0.43 on seeds 0, 2). With 1e-3 m/s the ratios were
    0.23-0.32 but process's detected windows begin up to 0.25 s before the vehicle is still
    and the velocity there was 7 sigma off (0.007 m/s against 0.001); with 5e-3 m/s 0.25,
    0.29, 0.25 with every velocity error within 2.7 sigma over the runs (1.7 inside the stops);
    with 0.01 m/s 0.25, 0.45, 0.25. A measured choice, not a derivation.

    Does ``dr-kf``'s velocity sigma at the stops cover its error with it (issue 15: an
    along-track ``(error / sigma)^2`` of 2.2-2.9 had been reported on seeds 0-9 at 2 Hz)?
    Measured over 30 seeds (``benchmarks/stop_sigma_dr_kf.py 30``: the radar stop-and-go
    drive above, the truth's stops with 1 s margins; the mean over a stop's output rows per
    seed, then over seeds with a Student-t 95 % interval): along-track 0.250 (0.204-0.295),
    at the 2 Hz measurement epochs 0.222 (0.179-0.265), over each stop's first 3 s 0.255
    (0.177-0.333), cross-track 0.219 (0.181-0.256); seeds 0-9 range 0.10-0.49 and seeds
    10-29 0.08-0.47 (no difference between them); with a 2 Hz radar 0.251 (0.198-0.304);
    through ``inmotion process`` (its detected stops, 10 Hz rows) 0.318 (0.273-0.363), first
    3 s 1.07 (0.90-1.24). The sigma at the stops is not too small (if anything about twice
    the error's RMS, since the floor also covers the roll-out at a detected window's edge):
    no defect, no change; the 2.2-2.9 was not reproduced by any of these statistics."""
    return {"zupt_noise_m_s": ZUPT_STILL_M_S} if calm_simulation(meta) else {}


def check_stops(raw) -> np.ndarray:
    """Stop windows ``[[start, end], ...]`` [s] (a configuration's ``stops_s``) as an (S, 2)
    array; :class:`BadInput` unless each is two finite times with ``end >= start``."""
    if any(len(w) != 2 for w in raw):
        raise BadInput("stops_s: each stop is [start, end] seconds", file="config")
    st = np.array(raw, dtype=float).reshape(-1, 2)
    if not np.all(np.isfinite(st)) or np.any(st[:, 1] < st[:, 0]):
        raise BadInput("stops_s: each stop is [start, end] seconds with end >= start",
                       file="config")
    return st


class VelocityAidedRun:
    """A SINS (+ DR) aided by one forward-velocity sensor, run over a log chunk by chunk.

    Parameters
    ----------
    init : NavState
        Start of the SINS and the DR.
    layout : Layout
        Must hold ``phi, dv, dp, eps, nabla``; ``phi_D, dp_D`` (the DR), ``mount``, ``dk``
        optional (mounting angles and scale factor are estimated only: the DR keeps its
        nominal mounting).
    model : error_model.ErrorModel on ``layout``
    P0 : (n, n) initial covariance
    use : dict group -> bool (:data:`GROUPS`)
    noise : dict: ``attitude_rad``, ``position_m``, ``velocity_b_m_s`` (3: lateral, forward,
        vertical), ``height_m``, ``nhc_m_s`` (1-sigma of each row), ``dr_position_m2_s``
        (DR position random-walk density)
    gates : dict group -> chi-square threshold of its NIS (0: never rejected)
    step_rows : IMU rows per filter epoch;  meas_every, out_every : in filter epochs
    C_bm, lever_arm_b : the velocity sensor's nominal mounting and lever arm (the DR, and the
        lever-arm correction of the ``sensor_velocity`` samples, :func:`imu_point_speed`)
    nhc_mount : the NHC rows carry the mounting columns
    closed_loop : feed the estimate back (False: open loop);  feedback_every : measurement
        epochs per feedback
    smooth : forward-backward: record the forward pass and return the Rauch-Tung-Striebel
        smoothed outputs (:mod:`inmotion.estimation.smoother`)
    invariant_velocity : feed back in the right-invariant velocity error
        (:class:`~inmotion.estimation.engine.ErrorStateFilter`, module docstring "Invariant
        velocity error"; the DR blocks keep theirs: the DR has no velocity state)
    """

    def __init__(self, init: NavState, layout: Layout, model: em.ErrorModel, P0, *, use: dict,
                 noise: dict, gates: dict, step_rows: int, meas_every: int = 1,
                 out_every: int = 1, C_bm=None, lever_arm_b=None, nhc_mount: bool = True,
                 closed_loop: bool = True, feedback_every: int = 1, smooth: bool = False,
                 stops_s=(), second_order: bool = True, invariant_velocity: bool = False):
        for name in ("phi", "dv", "dp", "eps", "nabla"):
            if name not in layout:
                raise ValueError(f"the velocity-aided filter needs block {name!r} in the layout")
        self.use = {g: bool(use.get(g, False)) for g in GROUPS}
        #: [start, end] windows [s] in which the vehicle stands still: a zero-velocity update
        #: at every measurement epoch inside one (group ``zero_velocity``, when used)
        self.stops_s = check_stops(list(stops_s))
        self.filter = ErrorStateFilter(
            init, layout, model, P0,
            _measurements(self.use, noise, gates, nhc_mount, second_order),
            step_rows=step_rows, feedback="closed" if closed_loop else "open",
            feedback_every=feedback_every, out_every=out_every, dr_mounting=C_bm,
            dr_lever_arm_m=lever_arm_b,
            dr_position_m2_s=float(noise.get("dr_position_m2_s", 0.0)), record=smooth,
            invariant_velocity=invariant_velocity)
        self.smooth = bool(smooth)
        #: the sensor's forward axis ``u_b = C_m^b [0, 1, 0]`` and lever arm ``l_b`` in b:
        #: the ``sensor_velocity`` samples are lever-arm corrected with them (:func:`imu_point_speed`)
        C = np.eye(3) if C_bm is None else np.asarray(C_bm, dtype=float)
        self.forward_b = np.ascontiguousarray(C[:, 1])
        self.lever_arm_b = (np.zeros(3) if lever_arm_b is None
                            else np.asarray(lever_arm_b, dtype=float).reshape(3))
        self.layout = layout
        self.with_dr = "dp_D" in layout
        self.init = init
        self.step = int(step_rows)
        self.meas_every = int(meas_every)
        self.out_every = int(out_every)
        #: IMU rows outside the sensor's span (the DR holds its position there) and inside
        #: sensor gaps (distance interpolated across), as :func:`dead_reckon` counts them
        self.rows_without_speed = 0
        self.rows_in_speed_gaps = 0
        #: measurement epochs whose speed-reading groups (:data:`READS_SPEED`) were skipped,
        #: the epoch's interval lying in a sensor gap or outside the sensor's span
        self.samples_skipped_blind = 0
        #: times the DR's position was put back on the SINS's as the speed came back after a
        #: gap or at the sensor's first sample (:func:`_dr_reseeds`)
        self.dr_reseeds = 0

    def run(self, t, dtheta, dvel, speed: SpeedData, h_baro=None, sensor="speed",
            progress=None, dtheta_dr=None) -> dict:
        """Process the rows of a log after ``init.t``; returns the outputs.

        Parameters
        ----------
        t : (N,) s;  dtheta, dvel : (N, 3) rad, m/s
        speed : SpeedData, the velocity sensor
        h_baro : callable ``t -> h`` [m] (NaN: none) or None
        sensor : its name for error messages
        progress : callable(fraction) or None
        dtheta_dr : (N, 3) rad, the DR's own gyro rows (default: the SINS's)

        Returns
        -------
        dict of arrays ``t`` (M,), ``x_sins`` (M, 10), ``sigma`` (M, n), ``states`` (M, n),
        ``cov_phi`` (M, 3, 3); row 0 is the state before the run, the last the end of it.
        """
        piece = (t, dtheta, dvel) if dtheta_dr is None else (t, dtheta, dvel, dtheta_dr)
        return self.run_stream([piece], len(t), speed, h_baro=h_baro, sensor=sensor,
                               progress=progress)

    def run_stream(self, pieces, n_rows: int, speed: SpeedData, h_baro=None, sensor="speed",
                   progress=None, select=None, output_times=None) -> dict:
        """:meth:`run` on rows that arrive in pieces (a log read in chunks).

        ``pieces`` yields consecutive blocks ``(t, dtheta, dvel)`` (or with ``dtheta_dr`` as a
        fourth array) of any sizes, ``n_rows`` rows in all. They are regrouped into the same
        engine chunks as one whole block would be (:data:`CHUNK_ROWS` rounded to whole filter
        epochs), so the outputs do not depend on where the pieces are cut. A source that
        yields other than ``n_rows`` rows is an error.

        ``select`` (None: every output row is kept): a callable ``select(t, sigma) -> (mask,
        stop)`` called on each chunk's output rows as they come (``t`` (m,) [s], ``sigma``
        ``{state: (m,)}`` the forward filter's 1-sigma); only the rows of ``mask`` are kept
        (so the outputs need not grow with the log: ``inmotion process`` keeps the rows its
        output rate writes), and ``stop`` ends the run after this chunk (the rows kept are
        those of the whole run: the filter is causal). With ``smooth`` the smoothed rows are
        returned at the rows kept.

        ``output_times`` (None: nothing): a callable given the times [s] of the output rows
        kept, chunk by chunk as they come, in order (the command line computes the truth
        rows the errors need meanwhile: :class:`inmotion.io.bundle_stream.TruthReducer`).

        ``pieces`` that are not a list or tuple (read from a file) are read ahead: the next
        piece read and checked in a reader thread while the filter runs on this one
        (:func:`inmotion._read_ahead.read_ahead`, issue 13; nothing else may read them
        meanwhile), the thread stopped when the run ends, however it ends.
        """
        if isinstance(pieces, (list, tuple)):
            return self._stream(pieces, n_rows, speed, h_baro, sensor, progress, select,
                                output_times)
        from .._read_ahead import read_ahead
        ahead = read_ahead(pieces)
        try:
            return self._stream(ahead, n_rows, speed, h_baro, sensor, progress, select,
                                output_times)
        finally:
            ahead.close()

    def _stream(self, pieces, n_rows, speed, h_baro, sensor, progress, select, output_times):
        def take(o):
            if select is None:
                kept = o, False
            else:
                mask, stop = select(o["t"], self.layout.as_dict(o["sigma"]))
                mask = np.asarray(mask, dtype=bool)
                kept = {k: v[mask] for k, v in o.items()}, bool(stop)
            if output_times is not None:
                output_times(kept[0]["t"])
            return kept

        if n_rows <= 0:
            raise ValueError("VelocityAidedRun.run needs at least one IMU row")
        if hasattr(speed, "load"):      # a long sensor table left on disk: its rows in memory,
            speed = speed.load()        # as before (_speed_on_chunk windows them per chunk)
        f = self.filter
        outs = [take(f.output_now())[0]]
        rec = ForwardRecord.for_filter(f, -(-n_rows // self.step)) if self.smooth else None
        stopped = False
        chunk = max(1, CHUNK_ROWS // self.step) * self.step
        max_gap = 5.0 * float(np.median(np.diff(speed.t[:GAP_SAMPLES])))
        groups = [g for g in GROUPS if self.use[g]]
        a = 0
        was_blind = False
        for block in regroup(pieces, chunk):
            tc, dth, dvl = block[0], block[1], block[2]
            b = a + len(tc)
            if b > n_rows:
                raise RuntimeError(f"the IMU source yields more than the {n_rows} rows it "
                                   "announced")
            edges = np.concatenate([[f.t], tc])
            ds, v, uncovered, in_gap = _speed_on_chunk(speed, edges, max_gap, sensor)
            self.rows_without_speed += int(uncovered.sum())
            self.rows_in_speed_gaps += int(in_gap.sum())
            ends = np.arange(self.step, b - a + self.step, self.step)
            ends[-1] = b - a
            epoch = f.epochs + 1 + np.arange(len(ends))
            rows = ends[epoch % self.meas_every == 0] - 1
            t_meas = tc[rows]
            hb = (h_baro(t_meas) if h_baro is not None and self.use["height"]
                  else np.full(len(rows), np.nan))
            # no sensor sample behind the speed there: the rows that read it are skipped
            blind = in_gap[rows] | uncovered[rows]
            self.samples_skipped_blind += int(blind.sum())
            for g in groups:
                if g == "zero_velocity":
                    inside = np.any((t_meas[:, None] >= self.stops_s[:, 0])
                                    & (t_meas[:, None] <= self.stops_s[:, 1]), axis=1)
                    if inside.any():
                        f.add_measurement(g, t_meas[inside], None)
                    continue
                data = (imu_point_speed(v[rows], dth[rows], np.diff(edges)[rows],
                                        self.forward_b, self.lever_arm_b)
                        if g == "sensor_velocity" else hb if g == "height" else None)
                if g in READS_SPEED and blind.any():
                    if blind.all():
                        continue
                    t_g, data = t_meas[~blind], None if data is None else data[~blind]
                else:
                    t_g = t_meas
                f.add_measurement(g, t_g, data)
            d_dr = block[3] if len(block) > 3 else None
            cuts, was_blind = _dr_reseeds(in_gap | uncovered, ends, was_blind, self.with_dr)
            s0 = 0
            for s1 in cuts + [b - a]:
                if s1 > s0:
                    o = f.add_imu(tc[s0:s1], dth[s0:s1], dvl[s0:s1], ds=ds[s0:s1],
                                  speed=v[s0:s1],
                                  dtheta_dr=None if d_dr is None else d_dr[s0:s1],
                                  flush=b == n_rows and s1 == b - a)
                    if rec is not None:
                        rec.append(o.pop("record"))
                    o, stopped = take(o)
                    outs.append(o)
                    if stopped:
                        break
                if s1 < b - a:              # the speed is back: the DR restarts at the SINS
                    f.reseed_dr_position()
                    self.dr_reseeds += 1
                s0 = s1
            if progress is not None:
                progress(b / n_rows)
            a = b
            if stopped:
                break
        if a != n_rows and not stopped:
            raise RuntimeError(f"the IMU source yielded {a} rows, not the {n_rows} announced")
        if f.epochs % self.out_every and not stopped:   # the last epoch, even off the grid
            outs.append(take(f.output_now())[0])
        res = {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}
        if rec is not None:             # the smoothed rows at the forward output's epochs
            sm = smooth_at_outputs(rec, f, times=None if select is None else res["t"])
            if not np.array_equal(sm["t"], res["t"]):
                raise RuntimeError("smoothed rows do not fall on the forward output rows")
            res.update(sm)
        return res

    def counts(self) -> dict:
        """Per group used: samples used, rejected and mean NIS per degree of freedom."""
        return self.filter.counts()
