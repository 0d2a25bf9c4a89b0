"""The generic plausibility checks of a configuration by field name
(:mod:`inmotion.config_checks`): a field's unit is read from its name's suffix."""
import pytest

from inmotion.config_checks import check_values
from inmotion.errors import BadInput


@pytest.mark.parametrize("field,value", [
    ("meas_noise_m_s", 5e-4),                  # speeds [m/s], not times: refused before
    ("od_noise_m_s", [0.01, 4e-5, 0.01]),      # session 18 as "shorter than any IMU period"
    ("r_min_m_s", 1e-4),
    ("gamma_deg_sqrt_s", 1e-4),                # deg sqrt(s)
    ("baro_tau_s", 1e-3),                      # a time at its 1 ms limit
])
def test_speeds_are_not_times(field, value):
    check_values({field: value})


@pytest.mark.parametrize("field,value,message", [
    ("baro_tau_s", 5e-4, "shorter than any IMU period"),
    ("main_period_s", 2e9, "longer than 30 years"),
    ("meas_noise_m_s", -0.01, "must not be negative"),
    ("speed_tolerance_m_s", 2e4, "m/s is beyond"),
])
def test_times_speeds_and_noises_still_checked(field, value, message):
    with pytest.raises(BadInput, match=message):
        check_values({field: value})
