"""Aiding measurements as plug-ins of the error-state engine (:mod:`inmotion.estimation.engine`).

A measurement is one small object: a ``name``, its degrees of freedom ``dof`` (rows), the data
it takes per sample (``data_size`` values), what it needs from the navigation state
(``needs_dr``: the dead reckoner), its noise parameters, an optional innovation gate, and one
numba **fill function** with the fixed signature :data:`FILL_SIG`::

    fill(xs, xd, aux, acc, data, p, offs, z, H, r) -> m

which writes ``m <= dof`` rows of the innovation vector ``z`` (measured minus predicted, so that
``z = H x + noise`` for the error state ``x``), the rows of ``H`` (on the columns given by the
layout's offsets ``offs``, indexed with the named constants of
:mod:`inmotion.estimation.layout`, never bare numbers) and the noise variances ``r``; ``m = 0``
means "no measurement now" (e.g. a NaN sample). The inputs are the SINS and dead-reckoning
kernel states ``xs``, ``xd`` (``[lat, lon, h, vE, vN, vU, q0..q3]``), ``aux = [t, omega_ib_b
(3), f_b (3)]`` (the filter epoch's mean compensated body rate [rad/s] and specific force
[m/s^2]), the sample ``data`` and the measurement's parameters ``p``. The engine hands ``z``,
``H``, ``r`` zeroed; ``r`` has ``2 dof`` entries: after the update's variances, a
measurement with :attr:`Measurement.test_variance` writes its residual test's own at
``r[dof:dof + m]``.

The engine's compiled loop calls the fill through a function pointer; :meth:`Measurement.rows`
is the Python form, the same function called on fresh buffers, returning ``(z, H, R)``.

Built-in kinds (each written once):

===================  ====  ===============================================================
class                dof   z and H (paper and equation)
===================  ====  ===============================================================
SinsDrAttitude       3     SINS minus DR ``[yaw, pitch, roll]`` (paper 002 eq. 44-51;
                           paper 000 Z1)
SinsDrVelocity       3     SINS minus DR velocity in the DR body frame (paper 002 eq. 52-55;
                           paper 000 eq. 11 on the mounting angles)
SinsDrPosition       3     SINS minus DR ``[lat, lon, h]`` (paper 002 eq. 44, 52)
ForwardVelocity      3     SINS velocity minus the sensor's speed along the SINS forward axis,
                           in body axes (the velocity-matching baseline ``od-velocity-kf``)
Nhc                  2     lateral and vertical body velocity are zero (paper 000 Z2,
                           eq. 32-38; paper 003 eq. 27-31)
Height               1     SINS minus barometric height
Position             3     SINS minus a position fix ``[lat, lon, h]``
ZeroVelocity         3     SINS velocity while parked (paper 003 eq. 11-13)
ZeroAngularRate      3     measured minus Earth rate in b while parked (gyro drift, heading)
===================  ====  ===============================================================

To add a sensor, write one class like these (``docs/extending.md``).
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from .._jit import njit, numba_module, real
from ..core import _kernels as K
from . import error_model as em
from .aiding_rows import _displacement_rows, _velocity_rows
from .layout import DK, DP, DP_D, DV, EPS, LEVER, MOUNT, NABLA, PHI, PHI_D, Layout
from .nav_ops import dcm_columns, dcm_of_q, euler_ypr, wrap_pi
from .second_order import bilinear_rows, bilinear_rows_blocks, cov_block

__all__ = ["ACC_SIZE", "accumulator_function", "Compiled", "dispatcher",
           "Measurement", "SinsDrAttitude", "SinsDrVelocity", "SinsDrPosition",
           "ForwardVelocity", "Nhc", "Height", "Position", "ZeroVelocity", "ZeroAngularRate",
           "fill_function", "AUX_SIZE"]

warnings.filterwarnings("ignore", message="First-class function type feature is experimental")


def _signatures():
    """``(FILL_SIG, ACC_SIG)`` (numba types: imported at first use, :mod:`inmotion._jit`)."""
    from numba import types
    f8 = types.float64[::1]
    return (types.int64(f8, f8, f8, f8, f8, f8, types.int64[::1], f8, types.float64[:, ::1],
                        f8),
            types.int64(f8, f8, f8, f8, types.float64, f8, f8))


def __getattr__(name):
    """:data:`FILL_SIG`, the one signature of every fill function, ``(xs, xd, aux, acc, data,
    p, offs, z, H, r) -> rows``, and :data:`ACC_SIG`, of every accumulator, ``(acc, xs,
    v_old, th_nb, dt, rd, p) -> 0``, made at first use (they are numba types)."""
    if name in ("FILL_SIG", "ACC_SIG"):
        return _signatures()[name == "ACC_SIG"]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: ``aux = [t, omega_ib_b x, y, z, f_b x, y, z, omega_nb_b x, y, z]``: its named slots
AUX_T, AUX_WIB, AUX_FB, AUX_WNB = 0, 1, 4, 7
AUX_SIZE = 10
#: values of a measurement's row accumulator
ACC_SIZE = 17
#: slots of paper 003's interval accumulator (:func:`_acc_sensor_interval`): interval length,
#: SINS displacement, body rotation, sensor displacement, its distance part, "a row had no
#: sensor distance"
ACC_T, ACC_DP, ACC_TH, ACC_D, ACC_W, ACC_BAD, ACC_FN = 0, 1, 4, 7, 10, 13, 14
#: parameter slots of paper 003's sensor channels: row sigmas, lever arm, C_v^b0's y column,
#: the rows' model floor per metre, and 1.0 for the displacement rows' exact attitude columns
#: (:func:`_fill_displacement`; 0.0: the sensor's displacement, as before issue 15's finding)
P_SIG, P_LEVER, P_FWD, P_FLOOR, P_EXACT = 0, 3, 6, 9, 10
#: values the engine writes at the end of the parameter row of a measurement that
#: :attr:`Measurement.wants_state`, before each fill: the fill's local filter's estimate of
#: ``[phi, dv]`` (6), then their 6 x 6 covariance row by row (36), then for a 3-angle
#: ``mount`` block its estimate (3, at :data:`ST_MOUNT`) and its covariance with ``[phi, dv,
#: mount]`` (3 x 9 row by row, at :data:`ST_MOUNT_COV`), zeros without one
#: (:func:`inmotion.estimation.engine._state_to_params`)
STATE_PARAMS = 72
#: where the mounting estimate and its covariance rows start within those values
ST_MOUNT, ST_MOUNT_COV = 42, 45


class Compiled:
    """A numba function with one fixed signature, compiled (or loaded from the disk cache) on
    first use, not at import: importing the measurements costs nothing, and a kernel that a
    fill calls is first loaded for a Python call, not as the fill's dependency (numba 0.6x
    then fails to box arrays that kernel returns to Python: "NRT_adapt_ndarray_to_python,
    'descr' is NULL").

    ``dispatcher`` is the compiled numba function (what the engine's loop calls through a
    function pointer); calling the object calls it.
    """

    def __init__(self, func, sig):
        self.py_func = func
        self.sig = sig
        self._dispatcher = None
        self.__doc__ = func.__doc__
        self.__name__ = func.__name__

    @property
    def dispatcher(self):
        if self._dispatcher is None:
            sig = _signatures()[self.sig == "acc"]
            self._dispatcher = numba_module().njit(sig, cache=True)(self.py_func)
        return self._dispatcher

    def __call__(self, *args):
        return self.dispatcher(*args)


def fill_function(func) -> Compiled:
    """``func`` as a fill function with :data:`FILL_SIG` (compiled on first use, cached)."""
    return Compiled(func, "fill")


def accumulator_function(func) -> Compiled:
    """``func`` as an accumulator with :data:`ACC_SIG` (compiled on first use, cached)."""
    return Compiled(func, "acc")


def dispatcher(f):
    """The numba function of a fill or accumulator (:class:`Compiled` or already compiled)."""
    return f.dispatcher if isinstance(f, Compiled) else real(f)


class Measurement:
    """Base class of a measurement plug-in (see the module docstring).

    Subclasses set the class attributes ``name``, ``dof``, ``data_size``, ``needs_dr`` and
    ``fill`` (from :func:`fill_function`) and implement :meth:`params`.

    Parameters
    ----------
    gate : float
        Chi-square threshold of the sample's NIS (0: never rejected); a rejected sample
        leaves the state untouched and is counted.
    name : str, optional
        Overrides the class name (two measurements of one kind in one filter).
    local : int or None, optional
        The local filter it updates in a bank (default 0; ``None``: every local filter, the
        noise scaled by each one's ``r_scale``).
    """

    name = "measurement"
    dof = 0
    data_size = 0
    needs_dr = False
    fill = None
    #: per-row accumulator (:data:`ACC_SIG`) and the row data it takes
    accumulate = None
    row_data_size = 0
    #: the local filter it updates (``None``: every one, shared)
    local = 0
    #: fault isolation (paper 003 eq. 42) and the passing tests before a return
    isolate = False
    return_tests = 1
    #: keep the NIS series;  fill aux[7:10] (body rate w.r.t. n)
    log_nis = False
    needs_body_rate = False
    #: the engine writes the local filter's ``[phi, dv]`` estimate and covariance at the end
    #: of the parameter row before each fill (:data:`STATE_PARAMS`)
    wants_state = False
    #: the attitude block of that estimate: ``phi`` (the SINS's), or ``phi_D`` for rows
    #: resolved with the DR's attitude
    state_attitude = "phi"
    #: its fill over the sums of several intervals' accumulators is the measurement over
    #: their span (the engine's ``return_span``, issue 15: a displacement, not a velocity)
    spans = False
    #: the fill also writes each row's variance for the residual test (the gate statistic,
    #: the NIS log, the isolation and return decisions) at ``r[dof + i]`` (``i < m``; 0 or
    #: not written: the row's ``r[i]``), where it differs from the update's ``r[i]``: e.g. a
    #: row whose ``r`` is inflated for an error correlated over intervals, so that the gain is
    #: honest, while a single interval's residual has its marginal variance (the engine's
    #: docstring, "Test variances"). The engine hands ``r`` with ``2 dof`` entries, zeroed.
    test_variance = False

    def __init__(self, *, gate: float = 0.0, name: str | None = None, local="default"):
        if not (gate >= 0.0 and math.isfinite(gate)):
            raise ValueError(f"{type(self).__name__}: gate must be a finite chi-square "
                             f"threshold >= 0, got {gate!r}")
        self.gate = float(gate)
        if name is not None:
            self.name = name
        if local != "default":
            self.local = None if local is None else int(local)

    def params(self) -> np.ndarray:
        """The parameter vector ``p`` handed to the fill function (SI)."""
        return np.zeros(0)

    def rows(self, nav, data=None, layout: Layout | None = None, state=None):
        """The Python form: ``(z, H, R)`` at the navigation state ``nav``.

        ``nav`` is an :class:`~inmotion.estimation.engine.ErrorStateFilter` (its current SINS,
        DR and last row's rates) or a tuple ``(xs, xd, aux[, acc])`` of kernel arrays;
        ``layout`` defaults to the filter's. ``state``: for a measurement that
        :attr:`wants_state`, the :data:`STATE_PARAMS` values the engine would hand it (its
        filter's estimate and covariance; zeros by default). Returns ``z`` (m,), ``H`` (m,
        n), ``R`` (m, m) diagonal; ``m = 0`` when the sample gives no measurement.
        """
        if isinstance(nav, tuple):
            nav = tuple(np.ascontiguousarray(a, dtype=float) for a in nav)
            xs, xd, aux = nav[:3]
            acc = nav[3] if len(nav) > 3 else np.zeros(ACC_SIZE)
            if len(aux) < AUX_SIZE:
                aux = np.concatenate([aux, np.zeros(AUX_SIZE - len(aux))])
        else:
            xs, xd, aux, acc = nav.kernel_states()
            layout = layout or nav.layout
        if layout is None:
            raise ValueError("rows() needs the layout when nav is a tuple of arrays")
        d = np.ascontiguousarray(np.zeros(0) if data is None else np.atleast_1d(data),
                                 dtype=float)
        if d.shape != (self.data_size,):
            raise ValueError(f"{self.name}: a sample holds {self.data_size} values, got "
                             f"shape {d.shape}")
        z = np.zeros(self.dof)
        H = np.zeros((self.dof, layout.n))
        r = np.zeros(2 * self.dof)      # r, then the test's variances (test_variance)
        p = np.asarray(self.params(), dtype=float)
        if self.wants_state:             # no filter here: a zero estimate and covariance
            st = np.zeros(STATE_PARAMS) if state is None else np.asarray(state, float)
            if st.shape != (STATE_PARAMS,):
                raise ValueError(f"{self.name}: state holds {STATE_PARAMS} values, got shape "
                                 f"{st.shape}")
            p = np.r_[p, st]
        m = self.fill(xs, xd, aux, acc, d, np.ascontiguousarray(p), layout.offsets(), z, H, r)
        return z[:m], H[:m], np.diag(r[:m])

    def check(self, layout: Layout):
        """Raise ``ValueError`` if ``layout`` lacks a block this measurement writes."""

    def __repr__(self):
        return f"{type(self).__name__}(name={self.name!r}, dof={self.dof}, gate={self.gate})"


def _need(layout, meas, *blocks):
    for b in blocks:
        if b not in layout:
            raise ValueError(f"measurement {meas.name!r} needs state block {b!r} in the "
                             f"layout {layout!r}")


def _noise3(values, what):
    v = np.broadcast_to(np.asarray(values, dtype=float), (3,)).copy()
    if not np.all(np.isfinite(v)) or np.any(v <= 0.0):
        raise ValueError(f"{what} must be finite and > 0, got {values!r}")
    return v


def _mounting(C):
    C = np.eye(3) if C is None else np.array(C, dtype=float)
    if C.shape != (3, 3) or not np.all(np.isfinite(C)):
        raise ValueError(f"a mounting matrix must be a finite (3, 3), got {C!r}")
    return C


def _noise1(value, what):
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{what} must be finite and > 0, got {value!r}")
    return v


# ----------------------------------------------------------------------------- shared rows
@njit(cache=True)
def body_velocity_rows(z, H, r, m, C_bn, dv_n, r_vel, o_dv, o_att, V, o_dk, dk_vec, o_mount,
                       VM):
    """Fill rows ``m .. m+2``: a velocity difference ``dv_n`` (n frame) resolved in body axes.

    ``z = C_n^b dv_n`` with ``H = C_n^b [dv: I, att: -[v x] (V), dk: -dk_vec, mount: -VM]``
    and the noises ``r_vel`` (lateral, forward, vertical). Serves the SINS-minus-DR velocity
    (paper 002 eq. 52-55, paper 000 eq. 11: ``att`` = DR attitude, :func:`error_model.
    dr_velocity_rows`) and the SINS-minus-sensor velocity (``att`` = SINS attitude,
    :func:`error_model.sensor_velocity_rows`). ``o_dk`` / ``o_mount`` < 0: no such block.
    """
    for i in range(3):
        r[m + i] = r_vel[i]
        for j in range(3):
            c = C_bn[i, j]
            z[m + i] += c * dv_n[j]
            H[m + i, o_dv + j] = c
            if o_dk >= 0:
                H[m + i, o_dk] -= c * dk_vec[j]
            for l in range(3):
                H[m + i, o_att + l] -= c * V[j, l]
                if o_mount >= 0:
                    H[m + i, o_mount + l] -= c * VM[j, l]


# ----------------------------------------------------------------------------- SINS minus DR
@fill_function
def _fill_sins_dr_attitude(xs, xd, aux, acc, data, p, offs, z, H, r):
    C_S = dcm_of_q(xs[K.Q0:K.Q3 + 1])
    C_D = dcm_of_q(xd[K.Q0:K.Q3 + 1])
    d = euler_ypr(C_S) - euler_ypr(C_D)
    E_S = em.euler_rows(C_S)
    E_D = em.euler_rows(C_D)
    o_phi, o_phiD = offs[PHI], offs[PHI_D]
    for i in range(3):
        z[i] = wrap_pi(d[i])
        r[i] = p[0]
        for j in range(3):
            H[i, o_phi + j] = E_S[i, j]
            H[i, o_phiD + j] = -E_D[i, j]
    return 3


class SinsDrAttitude(Measurement):
    """SINS minus DR attitude ``[yaw, pitch, roll]`` wrapped to +-pi (paper 002 eq. 44-51,
    paper 000 Z1): ``H = euler_rows(C_S)`` on ``phi``, ``-euler_rows(C_D)`` on ``phi_D``
    (paper 000 eq. 25-27, :func:`error_model.euler_rows`).

    Parameters
    ----------
    sigma_rad : 1-sigma of each row [rad]
    """

    name, dof, needs_dr = "attitude", 3, True
    fill = staticmethod(_fill_sins_dr_attitude)

    def __init__(self, sigma_rad: float, **kw):
        super().__init__(**kw)
        self.sigma_rad = _noise1(sigma_rad, "attitude sigma_rad")

    def params(self):
        return np.array([self.sigma_rad ** 2])

    def check(self, layout):
        _need(layout, self, "phi", "phi_D")


@fill_function
def _fill_sins_dr_velocity(xs, xd, aux, acc, data, p, offs, z, H, r):
    # z_n = v_S - v_D, H_n = [dv: I, phi_D: -[v x], dk: -v, mount: -[v x] C_D]; applied as
    # C_n^b z_n with the DR attitude, whose rows have the independent noises (lateral,
    # forward, vertical): the sensor's white noise lies along its forward axis only
    v = xd[K.VE:K.VU + 1]
    C_D = dcm_of_q(xd[K.Q0:K.Q3 + 1])
    C_bn = C_D.T
    st = p[p.shape[0] - STATE_PARAMS:]
    mounted = p[3] != 0.0 and offs[MOUNT] >= 0
    if mounted:
        # at the mounting estimate (issue 15, session 21; it stays in the state, never fed
        # back): the DR's velocity turned by it, exp([(C_D a) x]) v_D, and z below keeps the
        # innovation the engine forms, z - H x, equal to the prediction there
        a_n = K.qrotate(xd[K.Q0:K.Q3 + 1], (st[ST_MOUNT], st[ST_MOUNT + 1], st[ST_MOUNT + 2]))
        vr = K.qrotate(K.quat_from_rotvec(a_n), (v[0], v[1], v[2]))
        v = np.array([vr[0], vr[1], vr[2]])
    V = em.skew(v)
    # dv_D on the mounting angles (eq. 11), formed only with a mount block (sins-dr's where
    # the mounting is not given), column by column, [v x] C_D = [v x C_D[:, j]]: a matrix
    # product is a BLAS call in numba, whose first use imports scipy.linalg (0.17 s of a
    # command-line run ahead of time, issue 13); without the block VC is never read
    VC = V
    if offs[MOUNT] >= 0:
        VC = np.empty((3, 3))
        for j in range(3):
            c = K.cross(v, C_D[:, j])
            VC[0, j], VC[1, j], VC[2, j] = c[0], c[1], c[2]
    body_velocity_rows(z, H, r, 0, C_bn, xs[K.VE:K.VU + 1] - v, p,
                       offs[DV], offs[PHI_D], V, offs[DK], v, offs[MOUNT], VC)
    if mounted:
        o_m = offs[MOUNT]
        for i in range(3):
            for j in range(3):
                z[i] += H[i, o_m + j] * st[ST_MOUNT + j]
    if p[3] != 0.0:          # second order: the filter's [phi_D, dv] at the row's end
        bilinear_rows(z, H, r, st, offs[DV], 0, 3)
    return 3


class SinsDrVelocity(Measurement):
    """SINS minus DR velocity resolved in the DR body frame (paper 002 eq. 52-55; with a
    ``mount`` block, paper 000 eq. 11's ``-[v x] C_b^n`` on the mounting angles; with ``dk``,
    ``-v``).

    Parameters
    ----------
    sigma_m_s : (3,) 1-sigma of the rows in body axes (lateral, forward, vertical) [m/s]
    second_order : the rows' bilinear term in the DR's attitude error and the SINS's velocity
        error (:mod:`~inmotion.estimation.second_order`, the DR's ``phi_D`` in place of
        ``phi``: the rows are resolved with the DR's attitude; default on)
    """

    name, dof, needs_dr = "velocity", 3, True
    fill = staticmethod(_fill_sins_dr_velocity)
    state_attitude = "phi_D"

    def __init__(self, sigma_m_s, second_order: bool = True, **kw):
        super().__init__(**kw)
        self.sigma_m_s = _noise3(sigma_m_s, "velocity sigma_m_s")
        self.wants_state = bool(second_order)

    def params(self):
        return np.r_[self.sigma_m_s ** 2, 1.0 if self.wants_state else 0.0]

    def check(self, layout):
        _need(layout, self, "dv", "phi_D")


@fill_function
def _fill_sins_dr_position(xs, xd, aux, acc, data, p, offs, z, H, r):
    r_m, r_n = K.radii(xs[K.LAT])
    scale = (r_m + xs[K.H], (r_n + xs[K.H]) * math.cos(xs[K.LAT]), 1.0)
    o_dp, o_dpD = offs[DP], offs[DP_D]
    for i in range(3):
        z[i] = xs[K.LAT + i] - xd[K.LAT + i]
        r[i] = (p[0] / scale[i]) ** 2
        H[i, o_dp + i] = 1.0
        H[i, o_dpD + i] = -1.0
    return 3


class SinsDrPosition(Measurement):
    """SINS minus DR ``[lat, lon, h]`` (rad, rad, m; paper 002 eq. 44, 52): ``I`` on ``dp``,
    ``-I`` on ``dp_D``.

    Parameters
    ----------
    sigma_m : 1-sigma of each row [m] (converted to rad with the radii)
    """

    name, dof, needs_dr = "position", 3, True
    fill = staticmethod(_fill_sins_dr_position)

    def __init__(self, sigma_m: float, **kw):
        super().__init__(**kw)
        self.sigma_m = _noise1(sigma_m, "position sigma_m")

    def params(self):
        return np.array([self.sigma_m])

    def check(self, layout):
        _need(layout, self, "dp", "dp_D")


# ----------------------------------------------------------------------------- SINS alone
@njit(cache=True)
def _body_velocity_row(z, H, r, i, row, dv_n, r_i, o_dv, o_att, v, o_dk, dk_vec, o_mount,
                       vm0, vm1, vm2):
    """Row ``i`` of :func:`body_velocity_rows` with ``C_bn``'s row ``row``, ``V = [v x]`` and
    ``VM``'s columns ``vm0, vm1, vm2`` as 3-tuples (no arrays; the same sums in the same
    order)."""
    r[i] = r_i
    zi = z[i]
    for j in range(3):
        zi += row[j] * dv_n[j]
        H[i, o_dv + j] = row[j]
    z[i] = zi
    if o_dk >= 0:
        h = H[i, o_dk]
        for j in range(3):
            h -= row[j] * dk_vec[j]
        H[i, o_dk] = h
    # [v x] = [[0, -v2, v1], [v2, 0, -v0], [-v1, v0, 0]]
    H[i, o_att] -= row[0] * 0.0 + row[1] * v[2] - row[2] * v[1]
    H[i, o_att + 1] -= -row[0] * v[2] + row[1] * 0.0 + row[2] * v[0]
    H[i, o_att + 2] -= row[0] * v[1] - row[1] * v[0] + row[2] * 0.0
    if o_mount >= 0:
        H[i, o_mount] -= row[0] * vm0[0] + row[1] * vm0[1] + row[2] * vm0[2]
        H[i, o_mount + 1] -= row[0] * vm1[0] + row[1] * vm1[1] + row[2] * vm1[2]
        H[i, o_mount + 2] -= row[0] * vm2[0] + row[1] * vm2[1] + row[2] * vm2[2]


@fill_function
def _fill_forward_velocity(xs, xd, aux, acc, data, p, offs, z, H, r):
    # z_n = v_S - C_S [0, speed, 0], H_n = [dv: I, phi: -[v x], mount: -[v_s x] C_S,
    # dk: -v_s] (error_model.sensor_velocity_rows), applied as C_n^b z_n (SINS attitude);
    # scalar code (no allocation): C_S's columns c0, c1, c2 are C_n^b's rows
    speed = data[0]
    if math.isnan(speed):
        return 0
    c0, c1, c2 = dcm_columns(xs)
    v = (xs[K.VE], xs[K.VN], xs[K.VU])
    v_s = (c1[0] * speed, c1[1] * speed, c1[2] * speed)
    dv = (v[0] - v_s[0], v[1] - v_s[1], v[2] - v_s[2])
    vm0, vm1, vm2 = K.cross(v_s, c0), K.cross(v_s, c1), K.cross(v_s, c2)   # [v_s x] C_S
    o_dv, o_phi, o_dk, o_mount = offs[DV], offs[PHI], offs[DK], offs[MOUNT]
    _body_velocity_row(z, H, r, 0, c0, dv, p[0], o_dv, o_phi, v, o_dk, v_s, o_mount, vm0, vm1,
                       vm2)
    _body_velocity_row(z, H, r, 1, c1, dv, p[1], o_dv, o_phi, v, o_dk, v_s, o_mount, vm0, vm1,
                       vm2)
    _body_velocity_row(z, H, r, 2, c2, dv, p[2], o_dv, o_phi, v, o_dk, v_s, o_mount, vm0, vm1,
                       vm2)
    if p[3] != 0.0:          # second order: the filter's [phi, dv] at the row's end
        bilinear_rows(z, H, r, p[p.shape[0] - STATE_PARAMS:], o_dv, 0, 3)
    return 3


class ForwardVelocity(Measurement):
    """SINS velocity minus a forward-velocity sensor's speed along the SINS forward axis, in
    body axes (velocity matching; :func:`error_model.sensor_velocity_rows`): ``C_n^b`` times
    ``[dv: I, phi: -[v x], mount: -[v_s x] C_b^n, dk: -v_s]``.

    Sample: ``[speed]`` [m/s] (NaN: none).

    Parameters
    ----------
    sigma_m_s : (3,) 1-sigma of the rows in body axes (lateral, forward, vertical) [m/s]
    second_order : the rows' bilinear term in the attitude and velocity errors, its variance
        into the noise and its value at the estimate out of the innovation, from the filter's
        own estimate and covariance (:mod:`~inmotion.estimation.second_order`; default on)
    """

    name, dof, data_size = "sensor_velocity", 3, 1
    fill = staticmethod(_fill_forward_velocity)

    def __init__(self, sigma_m_s, second_order: bool = True, **kw):
        super().__init__(**kw)
        self.sigma_m_s = _noise3(sigma_m_s, "forward velocity sigma_m_s")
        self.wants_state = bool(second_order)

    def params(self):
        return np.r_[self.sigma_m_s ** 2, 1.0 if self.wants_state else 0.0]

    def check(self, layout):
        _need(layout, self, "phi", "dv")


@njit(cache=True)
def _cvn_row(p, k, c0, c1, c2):
    """Row ``k`` of ``C_vn = C_v^b0^T C_n^b`` (``C_v^b0`` row by row in ``p[2:11]``, C_n^b's
    rows ``c0, c1, c2``) as a 3-tuple."""
    a0, a1, a2 = p[2 + k], p[5 + k], p[8 + k]
    return (a0 * c0[0] + a1 * c1[0] + a2 * c2[0], a0 * c0[1] + a1 * c1[1] + a2 * c2[1],
            a0 * c0[2] + a1 * c1[2] + a2 * c2[2])


@njit(cache=True)
def _nhc_row(z, H, r, i, cv, v, vb_row, p0, o_dv, o_phi, o_mount, with_mount):
    """Row ``i`` of the NHC: ``C_vn``'s row ``cv``, ``[v_b x]``'s row ``vb_row``;
    ``with_mount`` 3: the columns of the 3-angle ``mount`` block, 2: of the 2-angle (x, z)
    block (the pitch and yaw of paper 003's sensor mounting), 0: none."""
    z[i] = cv[0] * v[0] + cv[1] * v[1] + cv[2] * v[2]
    r[i] = p0
    # C_vn [v x], [v x] = [[0, -v2, v1], [v2, 0, -v0], [-v1, v0, 0]]
    cx = (cv[1] * v[2] - cv[2] * v[1], -cv[0] * v[2] + cv[2] * v[0],
          cv[0] * v[1] - cv[1] * v[0])
    for j in range(3):
        H[i, o_dv + j] = cv[j]
        H[i, o_phi + j] = -cx[j]
        if with_mount == 3:
            H[i, o_mount + j] = -vb_row[j]
        elif with_mount == 2 and j != 1:
            H[i, o_mount + j // 2] = -vb_row[j]


@fill_function
def _fill_nhc(xs, xd, aux, acc, data, p, offs, z, H, r):
    # z = [v_x, v_z] of C_v^b0^T C_n^b v (SINS, vehicle frame); H: C_vn on dv, -C_vn [v x]
    # on phi, and with the mounting terms (p[1] = 3 or 2 angles) -[v_b x] on the mounting angles
    # (error_model.nhc_rows); p[2:11] is C_v^b0 row by row (identity: the IMU is the vehicle);
    # scalar code (no allocation)
    c0, c1, c2 = dcm_columns(xs)                   # the rows of C_n^b
    v = (xs[K.VE], xs[K.VN], xs[K.VU])
    r0, r1, r2 = _cvn_row(p, 0, c0, c1, c2), _cvn_row(p, 1, c0, c1, c2), _cvn_row(p, 2, c0, c1,
                                                                                  c2)
    o_dv, o_phi, o_mount = offs[DV], offs[PHI], offs[MOUNT]
    with_mount = int(p[1]) if o_mount >= 0 else 0
    second = p[11] != 0.0
    st = p[p.shape[0] - STATE_PARAMS:]
    if second and with_mount == 3:
        # at the mounting estimate (issue 15, session 21): the estimate stays in the state
        # (never fed back), so the rows are those of the vehicle frame it gives,
        # C_vn(a) = exp(-[a x]) C_vn (first order: the rows' own -[v_b x] a), and z keeps the
        # innovation the engine forms, z - H x, equal to the prediction there
        r0, r1, r2 = _rotated_rows(st[ST_MOUNT], st[ST_MOUNT + 1], st[ST_MOUNT + 2], r0, r1, r2)
    vb0 = r0[0] * v[0] + r0[1] * v[1] + r0[2] * v[2]
    vb1 = r1[0] * v[0] + r1[1] * v[1] + r1[2] * v[2]
    vb2 = r2[0] * v[0] + r2[1] * v[1] + r2[2] * v[2]
    _nhc_row(z, H, r, 0, r0, v, (0.0, -vb2, vb1), p[0], o_dv, o_phi, o_mount, with_mount)
    _nhc_row(z, H, r, 1, r2, v, (-vb1, vb0, 0.0), p[0], o_dv, o_phi, o_mount, with_mount)
    if second:               # second order: the filter's [phi, dv] at the row's end
        if with_mount == 3:
            for i in range(2):
                for j in range(3):
                    z[i] += H[i, o_mount + j] * st[ST_MOUNT + j]
            Ppsi, Pvpsi = _with_mount_spread(st, r0, r1, r2)
            bilinear_rows_blocks(z, H, r, (st[0], st[1], st[2]), (st[3], st[4], st[5]), Ppsi,
                                 cov_block(st, 3, 3), Pvpsi, o_dv, 0, 2)
        else:
            bilinear_rows(z, H, r, st, o_dv, 0, 2)
    return 2


@njit(cache=True)
def _with_mount_spread(st, r0, r1, r2):
    """The covariance blocks ``(P_psi_psi, P_dv_psi)`` (9-tuples, row by row) of
    :func:`~inmotion.estimation.second_order.bilinear_rows_blocks` for the NHC rows at the
    mounting estimate: the vehicle frame's rows ``e . exp(-[a x]) C_vn (v + dv)`` hold
    ``-e . ((C_vn^T a) x dv)`` besides ``e . (phi x dv)``, so the angle of the bilinear term is
    ``psi = phi - C_vn^T a`` (``C_vn``'s rows ``r0, r1, r2`` as n-frame vectors): its
    covariance with itself and with ``dv`` from the filter's ``[phi, dv, mount]`` covariance;
    its mean is ``phi``'s (the mounting's mean is where the rows are taken). Scalar code on
    tuples (no allocation: session 22)."""
    o = ST_MOUNT_COV
    A0 = _spread_row(st, o, r0[0], r1[0], r2[0])     # Cov(C^T mount, [phi, dv, mount]) rows
    A1 = _spread_row(st, o, r0[1], r1[1], r2[1])
    A2 = _spread_row(st, o, r0[2], r1[2], r2[2])
    c0, c1, c2 = (r0[0], r1[0], r2[0]), (r0[1], r1[1], r2[1]), (r0[2], r1[2], r2[2])
    Ppsi = (_psi_psi(st, A0, A0, 0, 0, c0), _psi_psi(st, A0, A1, 0, 1, c1),
            _psi_psi(st, A0, A2, 0, 2, c2), _psi_psi(st, A1, A0, 1, 0, c0),
            _psi_psi(st, A1, A1, 1, 1, c1), _psi_psi(st, A1, A2, 1, 2, c2),
            _psi_psi(st, A2, A0, 2, 0, c0), _psi_psi(st, A2, A1, 2, 1, c1),
            _psi_psi(st, A2, A2, 2, 2, c2))
    # Cov(dv_j, psi_i) = P_pv[i, j] - A_i[3 + j], row j
    Pvpsi = (st[9] - A0[3], st[15] - A1[3], st[21] - A2[3],
             st[10] - A0[4], st[16] - A1[4], st[22] - A2[4],
             st[11] - A0[5], st[17] - A1[5], st[23] - A2[5])
    return Ppsi, Pvpsi


@njit(cache=True)
def _spread_row(st, o, m0, m1, m2):
    """Row ``i`` of ``Cov(C_vn^T mount, [phi, dv, mount])`` (9-tuple), ``m_k`` row ``k`` of
    ``C_vn``'s ``i``-th entry; the mount's covariance rows at ``st[o:o + 27]``."""
    return (m0 * st[o] + m1 * st[o + 9] + m2 * st[o + 18],
            m0 * st[o + 1] + m1 * st[o + 10] + m2 * st[o + 19],
            m0 * st[o + 2] + m1 * st[o + 11] + m2 * st[o + 20],
            m0 * st[o + 3] + m1 * st[o + 12] + m2 * st[o + 21],
            m0 * st[o + 4] + m1 * st[o + 13] + m2 * st[o + 22],
            m0 * st[o + 5] + m1 * st[o + 14] + m2 * st[o + 23],
            m0 * st[o + 6] + m1 * st[o + 15] + m2 * st[o + 24],
            m0 * st[o + 7] + m1 * st[o + 16] + m2 * st[o + 25],
            m0 * st[o + 8] + m1 * st[o + 17] + m2 * st[o + 26])


@njit(cache=True)
def _psi_psi(st, Ai, Aj, i, j, cj):
    """``Cov(psi_i, psi_j) = P_pp - P_p,Cm - P_Cm,p + P_Cm,Cm`` (``cj``: column ``j`` of
    ``C_vn^T``, i.e. entry ``j`` of each row of ``C_vn``)."""
    return (st[6 + 6 * i + j] - Aj[i] - Ai[j]
            + (Ai[6] * cj[0] + Ai[7] * cj[1] + Ai[8] * cj[2]))


@njit(cache=True)
def _rotated_rows(a0, a1, a2, r0, r1, r2):
    """The rows of ``exp(-[a x]) R`` for ``R``'s rows ``r0, r1, r2``: each column of ``R``
    turned by the quaternion of ``-a``."""
    q = K.quat_from_rotvec((-a0, -a1, -a2))
    c0 = K.qrotate(q, (r0[0], r1[0], r2[0]))
    c1 = K.qrotate(q, (r0[1], r1[1], r2[1]))
    c2 = K.qrotate(q, (r0[2], r1[2], r2[2]))
    return (c0[0], c1[0], c2[0]), (c0[1], c1[1], c2[1]), (c0[2], c1[2], c2[2])


class Nhc(Measurement):
    """Non-holonomic constraint: the SINS velocity's lateral and vertical body components are
    zero for a vehicle that neither slips nor jumps (paper 000 Z2, eq. 32-38):
    ``H = [dv: C_n^b, phi: -C_n^b [v x]]`` rows x and z, and with ``mount_terms``
    ``-[v_b x]`` on ``mount`` (:func:`error_model.nhc_rows`; paper 000's eq. 37 as printed
    has none).

    With a nominal vehicle mounting ``C_v^b0`` the rows are those of the vehicle frame,
    ``C_vn = C_v^b0^T C_n^b`` in place of ``C_n^b`` (paper 003 eq. 29-31).

    Parameters
    ----------
    sigma_m_s : 1-sigma of each row [m/s]
    mount_terms : bool, carry the mounting columns
    mount_axes : ``"xyz"`` (the 3-angle ``mount`` block, paper 000's) or ``"xz"`` (the
        2-angle block of paper 003's sensor channels, pitch and yaw: the columns of x and z)
    vehicle_mounting : (3, 3) nominal ``C_v^b0`` (identity by default)
    second_order : as :class:`ForwardVelocity`'s (default on)
    """

    name, dof = "nhc", 2
    fill = staticmethod(_fill_nhc)

    def __init__(self, sigma_m_s: float, mount_terms: bool = True, vehicle_mounting=None,
                 mount_axes: str = "xyz", second_order: bool = True, **kw):
        super().__init__(**kw)
        self.wants_state = bool(second_order)
        self.sigma_m_s = _noise1(sigma_m_s, "NHC sigma_m_s")
        self.mount_terms = bool(mount_terms)
        if mount_axes not in ("xyz", "xz"):
            raise ValueError(f"NHC mount_axes must be 'xyz' or 'xz', got {mount_axes!r}")
        self.mount_axes = mount_axes
        self.C_vb0 = _mounting(vehicle_mounting)

    def params(self):
        return np.r_[self.sigma_m_s ** 2,
                     float(len(self.mount_axes)) if self.mount_terms else 0.0,
                     self.C_vb0.ravel(), 1.0 if self.wants_state else 0.0]

    def check(self, layout):
        _need(layout, self, "phi", "dv")
        if self.mount_terms and "mount" in layout and layout["mount"].stop - \
                layout["mount"].start != len(self.mount_axes):
            raise ValueError(f"NHC mount_terms with mount_axes {self.mount_axes!r} need a "
                             f"{len(self.mount_axes)}-angle 'mount' block")


@fill_function
def _fill_height(xs, xd, aux, acc, data, p, offs, z, H, r):
    if math.isnan(data[0]):
        return 0
    z[0] = xs[K.H] - data[0]
    r[0] = p[0]
    H[0, offs[DP] + 2] = 1.0
    return 1


class Height(Measurement):
    """SINS minus barometric (or any reference) height: ``1`` on ``dp_h``.

    Sample: ``[h]`` [m] (NaN: none). Parameters: ``sigma_m`` [m].
    """

    name, dof, data_size = "height", 1, 1
    fill = staticmethod(_fill_height)

    def __init__(self, sigma_m: float, **kw):
        super().__init__(**kw)
        self.sigma_m = _noise1(sigma_m, "height sigma_m")

    def params(self):
        return np.array([self.sigma_m ** 2])

    def check(self, layout):
        _need(layout, self, "dp")


@fill_function
def _fill_position(xs, xd, aux, acc, data, p, offs, z, H, r):
    if math.isnan(data[0]) or math.isnan(data[1]) or math.isnan(data[2]):
        return 0
    r_m, r_n = K.radii(xs[K.LAT])
    scale = (r_m + xs[K.H], (r_n + xs[K.H]) * math.cos(xs[K.LAT]), 1.0)
    for i in range(3):
        z[i] = xs[K.LAT + i] - data[i]
        r[i] = (p[i] / scale[i]) ** 2
        H[i, offs[DP] + i] = 1.0
    return 3


class Position(Measurement):
    """SINS minus a position fix ``[lat, lon, h]`` (rad, rad, m): ``I`` on ``dp``.

    Sample: ``[lat, lon, h]``. Parameters: ``sigma_m`` (3,) north, east, up [m].
    """

    name, dof, data_size = "position_fix", 3, 3
    fill = staticmethod(_fill_position)

    def __init__(self, sigma_m, **kw):
        super().__init__(**kw)
        self.sigma_m = _noise3(sigma_m, "position sigma_m")

    def params(self):
        return self.sigma_m.copy()

    def check(self, layout):
        _need(layout, self, "dp")


@fill_function
def _fill_zero_velocity(xs, xd, aux, acc, data, p, offs, z, H, r):
    for i in range(3):
        z[i] = xs[K.VE + i]
        r[i] = p[i]
        H[i, offs[DV] + i] = 1.0
    return 3


class ZeroVelocity(Measurement):
    """Zero-velocity update while parked (paper 003 eq. 11-13): ``z = v_SINS``, ``I`` on
    ``dv``. Parameters: ``sigma_m_s`` (3,) E, N, U [m/s] (the sway of a parked vehicle)."""

    name, dof = "zero_velocity", 3
    fill = staticmethod(_fill_zero_velocity)

    def __init__(self, sigma_m_s, **kw):
        super().__init__(**kw)
        self.sigma_m_s = _noise3(sigma_m_s, "zero-velocity sigma_m_s")

    def params(self):
        return self.sigma_m_s ** 2

    def check(self, layout):
        _need(layout, self, "dv")


@fill_function
def _fill_zero_rate(xs, xd, aux, acc, data, p, offs, z, H, r):
    # parked: the gyros measure the Earth rate, w_ib_b = C_n^b w_ie_n + eps + noise. With
    # C_n^b(computed) = C_n^b (I + [phi x]) the predicted rate is off by -C_n^b [w_ie x] phi,
    # so z = w_ib_b - C_n^b(computed) w_ie_n = eps + C_n^b [w_ie x] phi + noise
    # and a latitude error moves the predicted Earth rate: -C_n^b d(w_ie)/d(lat) on dp_lat
    C_bn = dcm_of_q(xs[K.Q0:K.Q3 + 1]).T
    lat = xs[K.LAT]
    w_ie = K.omega_ie_n(lat)
    W = em.skew(np.array([w_ie[0], w_ie[1], w_ie[2]]))
    CW = C_bn @ W
    dw = (0.0, -K.OMEGA_IE * math.sin(lat), K.OMEGA_IE * math.cos(lat))
    o_phi, o_eps, o_dp = offs[PHI], offs[EPS], offs[DP]
    for i in range(3):
        pred = 0.0
        dpred = 0.0
        for j in range(3):
            pred += C_bn[i, j] * w_ie[j]
            dpred += C_bn[i, j] * dw[j]
            H[i, o_phi + j] = CW[i, j]
        z[i] = aux[AUX_WIB + i] - pred
        r[i] = p[i]
        H[i, o_eps + i] = 1.0
        if o_dp >= 0:
            H[i, o_dp] = -dpred
    return 3


class ZeroAngularRate(Measurement):
    """Zero angular rate (w.r.t. the Earth) while parked: the epoch's mean compensated gyro
    rate minus the Earth rate in the computed body frame; ``I`` on ``eps``,
    ``C_n^b [w_ie x]`` on ``phi``, ``-C_n^b d w_ie / d lat`` on ``dp_lat``. Parameters: ``sigma_rad_s`` (3,) x, y, z [rad/s]: the
    rate noise over one filter epoch plus the vehicle's sway rate."""

    name, dof = "zero_rate", 3
    fill = staticmethod(_fill_zero_rate)

    def __init__(self, sigma_rad_s, **kw):
        super().__init__(**kw)
        self.sigma_rad_s = _noise3(sigma_rad_s, "zero-rate sigma_rad_s")

    def params(self):
        return self.sigma_rad_s ** 2

    def check(self, layout):
        _need(layout, self, "phi", "eps")


# ----------------------------------------------------------------------------- paper 003
@accumulator_function
def _acc_sensor_interval(a, xs, v_old, th_nb, dt, rd, p):
    """Over a measurement interval: ``a = [T, Delta P (3), Delta theta_nb (3), Delta D (3),
    Delta W (3), bad, F (3)]`` (``F = int f_n dt``, the SINS velocity change plus gravity) with the SINS displacement ``sum v dt`` (trapezoid), the body rotation
    w.r.t. n, the sensor's displacement ``sum C_b^n (w_b - f f^T [dtheta_nb x] l)`` (``f`` the
    nominal forward axis: the sensor reads the forward part of the lever term only,
    :mod:`~inmotion.estimation.aiding_rows`) and its distance
    part ``sum C_b^n w_b`` (``w_b = C_v^b0 [0, ds, 0]``); ``bad`` = 1 once a row has no
    sensor distance (``rd[0]`` NaN)."""
    a[ACC_T] += dt
    for i in range(3):
        a[ACC_TH + i] += th_nb[i]
        a[ACC_DP + i] += 0.5 * (v_old[i] + xs[K.VE + i]) * dt
        a[ACC_FN + i] += xs[K.VE + i] - v_old[i]      # f_n dt, less gravity below
    a[ACC_FN + 2] += K.gravity(xs[K.LAT], xs[K.H]) * dt
    ds = rd[0]
    if math.isnan(ds):
        a[ACC_BAD] = 1.0
        return 0
    Cnb = dcm_of_q(xs[K.Q0:K.Q3 + 1])
    # the row's distance along the forward axis at mid-row: the body turned by dtheta_nb
    # over the row, so C_b^n(mid) = C_b^n(end) (I - [dtheta_nb / 2 x]) (with the end's
    # attitude a 3 deg/s turn put 2 mm per 0.5 s into the lateral row, absorbed by the mount
    # state and released at every change of the turn rate: chi-square values of 50)
    w_b = np.empty(3)
    for i in range(3):
        w_b[i] = p[P_FWD + i] * ds
    hw0 = 0.5 * (th_nb[1] * w_b[2] - th_nb[2] * w_b[1])
    hw1 = 0.5 * (th_nb[2] * w_b[0] - th_nb[0] * w_b[2])
    hw2 = 0.5 * (th_nb[0] * w_b[1] - th_nb[1] * w_b[0])
    w_b[0] -= hw0
    w_b[1] -= hw1
    w_b[2] -= hw2
    lv0, lv1, lv2 = p[P_LEVER], p[P_LEVER + 1], p[P_LEVER + 2]
    f0, f1, f2 = p[P_FWD], p[P_FWD + 1], p[P_FWD + 2]
    along = (f0 * (th_nb[1] * lv2 - th_nb[2] * lv1) + f1 * (th_nb[2] * lv0 - th_nb[0] * lv2)
             + f2 * (th_nb[0] * lv1 - th_nb[1] * lv0))   # the forward part of dtheta x l
    cr = np.array([f0 * along, f1 * along, f2 * along])
    wn = Cnb @ w_b
    dn = Cnb @ (w_b - cr)
    for i in range(3):
        a[ACC_W + i] += wn[i]
        a[ACC_D + i] += dn[i]
    return 0


@fill_function
def _fill_sensor_velocity_n(xs, xd, aux, acc, data, p, offs, z, H, r):
    # paper 003 eq. 23-24 (aiding_rows): z = v_SINS - C_b^n (w_b - omega_nb x l), n frame
    v = data[0]
    if acc[ACC_BAD] != 0.0 or math.isnan(v):
        return 0
    Cnb = dcm_of_q(xs[K.Q0:K.Q3 + 1])
    w_b = np.empty(3)
    for i in range(3):
        w_b[i] = p[P_FWD + i] * v
    w_nb = aux[AUX_WNB:AUX_WNB + 3].copy()
    lv0, lv1, lv2 = p[P_LEVER], p[P_LEVER + 1], p[P_LEVER + 2]
    f0, f1, f2 = p[P_FWD], p[P_FWD + 1], p[P_FWD + 2]
    along = (f0 * (w_nb[1] * lv2 - w_nb[2] * lv1) + f1 * (w_nb[2] * lv0 - w_nb[0] * lv2)
             + f2 * (w_nb[0] * lv1 - w_nb[1] * lv0))     # the forward part of omega x l
    u_b = w_b - np.array([f0 * along, f1 * along, f2 * along])
    vs = Cnb @ u_b
    for i in range(3):
        z[i] = xs[K.VE + i] - vs[i]
        r[i] = p[P_SIG + i] ** 2
    _velocity_rows(H, (offs[PHI], offs[DV], offs[DK], offs[MOUNT], offs[LEVER]), Cnb, w_b, u_b,
                   w_nb, p[P_FWD:P_FWD + 3].copy())
    return 3


@fill_function
def _fill_displacement(xs, xd, aux, acc, data, p, offs, z, H, r):
    # paper 003 ref. 38 (aiding_rows): z = C_n^b (Delta P - Delta D) over the interval, b frame
    if acc[ACC_BAD] != 0.0 or acc[ACC_T] <= 0.0:
        return 0
    T = acc[ACC_T]
    C_bn = np.ascontiguousarray(dcm_of_q(xs[K.Q0:K.Q3 + 1]).T)
    dD = acc[ACC_D:ACC_D + 3].copy()
    # the sensor's distance error at the interval's start (half the forward variance for a
    # difference of two readings) is laid along the forward axis of the body as it was then:
    # in the end's frame it has a part (dtheta_nb x f) e_start across the forward axis, so a
    # turn puts forward noise into the lateral rows (the odometer's 5 mm quantization at
    # 3 deg/s: 5e-5 m/s, the size of the rows' other residuals on a simulated drive)
    th = acc[ACC_TH:ACC_TH + 3]
    f0, f1, f2 = p[P_FWD], p[P_FWD + 1], p[P_FWD + 2]
    tf = (th[1] * f2 - th[2] * f1, th[2] * f0 - th[0] * f2, th[0] * f1 - th[1] * f0)
    var_fwd = (p[P_SIG + 1] * T) ** 2
    # the rows' own model error, (floor * d)^2 with d the sensor's distance over the interval
    # (aided_kf.linearization_floor_per_m: the first-order rows' d c^2 / 2, issue 15)
    var_model = p[P_FLOOR] * p[P_FLOOR] * (dD[0] * dD[0] + dD[1] * dD[1] + dD[2] * dD[2])
    for i in range(3):
        zz = 0.0
        for j in range(3):
            zz += C_bn[i, j] * (acc[ACC_DP + j] - dD[j])
        z[i] = zz
        r[i] = (p[P_SIG + i] * T) ** 2 + 0.5 * var_fwd * tf[i] * tf[i] + var_model
    # the attitude columns (issue 15): z = C_n^b Delta P_n - Delta D_b (Delta D_n was summed
    # with the attitude at each row, so C_n^b(end) Delta D_n is the gyros' relative rotation
    # times the sensor's readings, free of the attitude error), so dz/dphi = -[Delta P_b x]
    # C_n^b, the SINS's displacement (p[P_EXACT] = 1); the sensor's (0, paper 003's form)
    # differs by -[z x] C_n^b, a product of the attitude error with the residual, whose
    # mounting and scale parts (2 cm over 7 m) are no longer small against a fine sensor's
    # noise: the rows then "see" a heading that a SINS turned about the vertical as a whole
    # (attitude and velocity) does not change (benchmarks/heading_symmetry.py)
    dA = acc[ACC_DP:ACC_DP + 3].copy() if p[P_EXACT] != 0.0 else dD
    _displacement_rows(H, (offs[PHI], offs[DV], offs[DK], offs[MOUNT], offs[LEVER]), C_bn, T,
                       C_bn @ dA, C_bn @ acc[ACC_W:ACC_W + 3].copy(),
                       acc[ACC_TH:ACC_TH + 3].copy(), p[P_FWD:P_FWD + 3].copy())
    # the velocity error drifts within the interval, dv(t) = dv_k - (t_k - t) ([f_n x] phi +
    # C_b^n nabla), so int dv dt = T dv_k - T^2 / 2 ([f_n x] phi + C_b^n nabla): in b,
    # -T^2 / 2 ([f_b x] C_n^b phi + nabla) (f_b: the interval's mean specific force). A
    # 1 arcmin tilt error gives 0.36 mm over 0.5 s, as large as the sensors' own noise.
    h2 = 0.5 * T * T
    # the interval's mean specific force, from the SINS velocity change plus gravity (the
    # Coriolis part, 2e-3 m/s^2 at 15 m/s, left out), in b at the interval's end
    fn = acc[ACC_FN:ACC_FN + 3] / T
    fb0 = C_bn[0, 0] * fn[0] + C_bn[0, 1] * fn[1] + C_bn[0, 2] * fn[2]
    fb1 = C_bn[1, 0] * fn[0] + C_bn[1, 1] * fn[1] + C_bn[1, 2] * fn[2]
    fb2 = C_bn[2, 0] * fn[0] + C_bn[2, 1] * fn[1] + C_bn[2, 2] * fn[2]
    o_phi, o_nab = offs[PHI], offs[NABLA]
    for j in range(3):
        c0, c1, c2 = C_bn[0, j], C_bn[1, j], C_bn[2, j]
        H[0, o_phi + j] -= h2 * (fb1 * c2 - fb2 * c1)
        H[1, o_phi + j] -= h2 * (fb2 * c0 - fb0 * c2)
        H[2, o_phi + j] -= h2 * (fb0 * c1 - fb1 * c0)
        if o_nab >= 0:
            H[j, o_nab + j] -= h2
    return 3


class _SensorChannel(Measurement):
    """A forward-velocity sensor of paper 003 (odometer, LDV) on a sub-filter with the
    ``dk``, ``mount`` = ``[alpha, gamma]`` and ``lever`` blocks
    (:data:`inmotion.estimation.aiding_rows.SUB_LAYOUT`).

    Row data: the sensor's distance over each IMU row [m] (NaN: not covered; the interval's
    sample is then skipped).

    Parameters
    ----------
    sigma_m_s : (3,) 1-sigma per row [m/s] (right, forward, up; displacement: times ``T``)
    lever_arm_m : (3,) nominal lever arm in b [m];  vehicle_mounting : (3, 3) nominal
        ``C_v^b0``;  local : the local filter it updates;  isolate, return_tests : FDI
    model_floor_per_m : the displacement rows' model error per metre of the interval's
        distance (each row's variance gets ``(model_floor_per_m * d)^2``; 0: none; the
        velocity form ignores it), :func:`inmotion.align.aided_kf.linearization_floor_per_m`
    exact_attitude_columns : the displacement rows' attitude columns from the SINS's
        displacement, the exact derivative (issue 15; the velocity form ignores it); False:
        from the sensor's, paper 003's form
    """

    dof, row_data_size = 3, 1
    accumulate = staticmethod(_acc_sensor_interval)
    needs_body_rate = True

    def __init__(self, sigma_m_s, *, lever_arm_m=None, vehicle_mounting=None, local=0,
                 isolate=False, return_tests=1, model_floor_per_m=0.0,
                 exact_attitude_columns=False, **kw):
        super().__init__(local=local, **kw)
        self.exact_attitude_columns = bool(exact_attitude_columns)
        self.sigma_m_s = _noise3(sigma_m_s, f"{self.name} sigma_m_s")
        self.model_floor_per_m = float(model_floor_per_m)
        if not (np.isfinite(self.model_floor_per_m) and self.model_floor_per_m >= 0.0):
            raise ValueError(f"{self.name} model_floor_per_m must be finite and >= 0, "
                             f"got {model_floor_per_m!r}")
        self.lever = np.zeros(3) if lever_arm_m is None else np.asarray(lever_arm_m, float)
        self.C_vb0 = _mounting(vehicle_mounting)
        self.isolate = bool(isolate)
        self.return_tests = int(return_tests)

    def params(self):
        return np.r_[self.sigma_m_s, self.lever, self.C_vb0[:, 1], self.model_floor_per_m,
                     float(self.exact_attitude_columns)]

    def check(self, layout):
        _need(layout, self, "phi", "dv", "dk", "mount", "lever")


class SensorVelocityNav(_SensorChannel):
    """Paper 003 eq. 23-24: SINS velocity minus the sensor's forward speed mapped to the IMU
    point (lever arm, nominal mounting) and to n, ``z = v_SINS - C_b^n (f v - f f^T
    (omega_nb^b x l))``, ``f = C_v^b0 [0, 1, 0]``; rows :func:`inmotion.estimation.aiding_rows._velocity_rows`.
    Sample: ``[v]`` [m/s] at the interval's end."""

    name, data_size = "sensor_velocity_n", 1
    fill = staticmethod(_fill_sensor_velocity_n)


class DisplacementIncrement(_SensorChannel):
    """Paper 003 (its ref. 38): the SINS displacement over the measurement interval minus
    the sensor's, in b at the interval's end; rows
    :func:`inmotion.estimation.aiding_rows._displacement_rows`. Sample: none (``[]``) at the
    interval's end; the row accumulator gathers the interval."""

    name, data_size = "displacement", 0
    fill = staticmethod(_fill_displacement)
    spans = True
