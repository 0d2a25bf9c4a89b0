"""Configuration fields that several methods share: one definition each (name, unit in the
name, bounds, description), the default given by the method.

A method declares ``gyro_drift_deg_h: float = cf.gyro_drift_deg_h(0.01)``: the field means the
same in every method that has it (its description and bounds are written once, here), while
each method keeps its own default (a navigation-grade paper setting, a MEMS one, ...).
"""

from __future__ import annotations

from pydantic import Field

__all__ = [
    "accel_bias_rw_ug_sqrt_h",
    "accel_bias_ug",
    "accel_vrw_ug_sqrt_hz",
    "attitude_noise_arcmin",
    "baro_noise_m",
    "confirm_s",
    "dk_sigma_ppm",
    "dk_tau_s",
    "dr_sees_gyro_drift",
    "false_alarm_rate",
    "filter_rate_hz",
    "gate_probability",
    "gyro_arw_deg_sqrt_h",
    "gyro_bias_rw_deg_h_sqrt_h",
    "gyro_drift_deg_h",
    "init_heading_sigma_deg",
    "init_position_sigma_m",
    "init_tilt_sigma_deg",
    "init_velocity_sigma_m_s",
    "invariant_velocity_error",
    "lever_arm_m",
    "measurement_rate_hz",
    "mount_sigma_arcmin",
    "mounting_arcmin",
    "nhc_noise_m_s",
    "out_stride",
    "output_interval_s",
    "smooth",
    "use_baro",
    "velocity_noise_m_s",
    "velocity_sensor",
]


def accel_bias_rw_ug_sqrt_h(default):
    """``accel_bias_rw_ug_sqrt_h`` (float)."""
    return Field(
        default, ge=0, description="accelerometer bias random walk [ug/sqrt(h)] (0: constant bias)"
    )


def accel_bias_ug(default):
    """``accel_bias_ug`` (float)."""
    return Field(default, ge=0, description="1-sigma accelerometer bias per axis [ug]")


def accel_vrw_ug_sqrt_hz(default):
    """``accel_vrw_ug_sqrt_hz`` (float)."""
    return Field(default, ge=0, description="accelerometer velocity random walk [ug/sqrt(Hz)]")


def attitude_noise_arcmin(default):
    """``attitude_noise_arcmin`` (float)."""
    return Field(
        default, gt=0, description="1-sigma of the SINS-minus-DR attitude measurement [arcmin]"
    )


def baro_noise_m(default):
    """``baro_noise_m`` (float)."""
    return Field(default, gt=0, description="1-sigma of the barometric height measurement [m]")


def confirm_s(default):
    """``confirm_s`` (float)."""
    return Field(
        default,
        ge=0,
        description="moving is declared after the test exceeds its threshold for this long [s]",
    )


def dk_sigma_ppm(default):
    """``dk_sigma_ppm`` (float)."""
    return Field(
        default,
        ge=0,
        description="1-sigma of the velocity sensor's scale-factor error (first-order Markov) "
        "[ppm]",
    )


def dk_tau_s(default):
    """``dk_tau_s`` (float)."""
    return Field(
        default, gt=0, description="correlation time of the scale-factor Markov process [s]"
    )


def dr_sees_gyro_drift(default):
    """``dr_sees_gyro_drift`` (bool)."""
    return Field(
        default,
        description="keep the -C_b^n eps term in the DR attitude rows (False: paper 000's printed"
        " F)",
    )


def false_alarm_rate(default):
    """``false_alarm_rate`` (float)."""
    return Field(default, gt=0, lt=1, description="false-alarm probability of the chi-square test")


def filter_rate_hz(default):
    """``filter_rate_hz`` (float)."""
    return Field(
        default,
        gt=0,
        description="Kalman prediction (and model relinearization) rate [Hz], rounded to whole "
        "IMU rows",
    )


def gate_probability(default):
    """``gate_probability`` (float)."""
    return Field(
        default,
        gt=0.5,
        le=1.0,
        description="chi-square gate probability per measurement group (1: no gate)",
    )


def gyro_arw_deg_sqrt_h(default):
    """``gyro_arw_deg_sqrt_h`` (float)."""
    return Field(default, ge=0, description="gyro angle random walk [deg/sqrt(h)]")


def gyro_bias_rw_deg_h_sqrt_h(default):
    """``gyro_bias_rw_deg_h_sqrt_h`` (float)."""
    return Field(
        default, ge=0, description="gyro bias random walk [deg/h/sqrt(h)] (0: constant drift)"
    )


def gyro_drift_deg_h(default):
    """``gyro_drift_deg_h`` (float)."""
    return Field(default, ge=0, description="1-sigma gyro drift (constant bias) per axis [deg/h]")


def init_heading_sigma_deg(default):
    """``init_heading_sigma_deg`` (float)."""
    return Field(default, gt=0, description="initial 1-sigma of the heading error [deg]")


def init_position_sigma_m(default):
    """``init_position_sigma_m`` (float)."""
    return Field(default, gt=0, description="initial 1-sigma of the position error per axis [m]")


def init_tilt_sigma_deg(default):
    """``init_tilt_sigma_deg`` (float)."""
    return Field(
        default, gt=0, description="initial 1-sigma of the level (pitch, roll) error [deg]"
    )


def init_velocity_sigma_m_s(default):
    """``init_velocity_sigma_m_s`` (float)."""
    return Field(default, gt=0, description="initial 1-sigma of the velocity error per axis [m/s]")


def invariant_velocity_error(default):
    """``invariant_velocity_error`` (bool)."""
    return Field(
        default,
        description="carry the covariance across each feedback in the right-invariant "
        "velocity error dv + phi x v (estimation.engine, 'Invariant velocity error'): a "
        "common turn of attitude and velocity about the vertical, which vehicle constraints "
        "and a speed cannot see, stays unseen, so the heading sigma does not shrink on "
        "information the data do not hold (false: the standard error-state EKF, the papers')",
    )


def lever_arm_m(default):
    """``lever_arm_m`` (Optional[tuple[float, float, float]])."""
    return Field(
        default,
        description="the sensor's position relative to the IMU in b [x, y, z] [m]; None: from "
        "meta.yaml, else zero",
    )


def measurement_rate_hz(default):
    """``measurement_rate_hz`` (float)."""
    return Field(
        default, gt=0, description="measurement update rate [Hz], rounded to whole filter epochs"
    )


def mount_sigma_arcmin(default):
    """``mount_sigma_arcmin`` (float)."""
    return Field(default, ge=0, description="initial 1-sigma of the mounting angles [arcmin]")


def mount_rw_arcmin_sqrt_s(default):
    """``mount_rw_arcmin_sqrt_s`` (float)."""
    return Field(
        default, ge=0,
        description="random walk of the mounting angles [arcmin/sqrt(s)]: an IMU that is not "
        "fixed in its vehicle (a rolling platform, a phone in a holder); 0: constants. "
        "noise_preset matched: meta.yaml's vehicle.mounting_rw_arcmin_sqrt_s where the "
        "configuration does not set it")


def mounting_arcmin(default):
    """``mounting_arcmin`` (Optional[tuple[float, float, float]])."""
    return Field(
        default,
        description="IMU mounting in the vehicle [alpha, beta, gamma] [arcmin], C_v^b = exp([A "
        "x]); None: vehicle_mounting_arcmin of meta.yaml, else zero",
    )


def nhc_noise_m_s(default):
    """``nhc_noise_m_s`` (float)."""
    return Field(
        default,
        gt=0,
        description="1-sigma of the NHC pseudo-measurement (lateral and vertical velocity) [m/s]",
    )


def out_stride(default):
    """``out_stride`` (int)."""
    return Field(
        default, ge=1, description="output the initial state, then every out_stride-th IMU epoch"
    )


def output_interval_s(default):
    """``output_interval_s`` (float)."""
    return Field(default, gt=0, description="spacing of the output rows [s]")


def smooth(default):
    """``smooth`` (bool)."""
    return Field(
        default,
        description="forward-backward: Rauch-Tung-Striebel smoothing over the whole run "
        "(estimation.smoother); sigma_forward_* keeps the forward filter's sigma",
    )


def second_order_rows(default=True):
    """``second_order_rows`` (bool)."""
    return Field(
        default,
        description="the body-frame velocity rows (NHC, the sensor's or the DR's velocity) "
        "taken at the mounting estimate and with their bilinear term in the attitude and "
        "velocity errors, its variance and its value at the estimate from the filter's own "
        "estimate and covariance "
        "(estimation.second_order; false: the first-order rows, as before issue 15's session "
        "21)",
    )


def use_baro(default):
    """``use_baro`` (bool)."""
    return Field(
        default,
        description="add the barometric height measurement h_SINS - h_baro (needs a baro table)",
    )


def velocity_noise_m_s(default):
    """``velocity_noise_m_s`` (float)."""
    return Field(
        default,
        gt=0,
        description="1-sigma of the velocity-difference measurement along the vehicle [m/s]",
    )


def velocity_sensor(default):
    """``velocity_sensor`` (Optional[Literal["radar", "ldv", "odometer"]])."""
    return Field(
        default,
        description="forward-velocity sensor: radar, ldv or odometer; None: the first present",
    )
