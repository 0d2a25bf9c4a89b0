"""Issue 15: a filter run with its default settings on an imported real log takes the noise
from the bundle's sensor spec, says where each value came from, carries its sigma columns and
warns in ``summary.json`` when its settings do not fit the data (skipped without the data)."""
import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from inmotion.cli.main import cli
from inmotion.reproductions.real import default_data_root

COMMA = default_data_root() / "comma2k19_rav4_60s"
needs_comma = pytest.mark.skipif(not COMMA.is_dir(), reason=f"comma2k19 not found at {COMMA}")


def _run(*a):
    return CliRunner().invoke(cli, ["-q", *map(str, a)])


@pytest.fixture(scope="module")
def comma_bundle(tmp_path_factory):
    out = tmp_path_factory.mktemp("c2k") / "b"
    r = _run("import", "comma2k19", COMMA, "-o", out)
    assert r.exit_code == 0, r.output
    return out


@needs_comma
def test_od_kf_defaults_on_comma2k19_take_the_phone_spec_and_warn(comma_bundle, tmp_path):
    """Before: 1175 m off after 1 km (117 %), heading 16 deg off, no warning, defaults of a
    navigation-grade IMU. Now the importer's assumed phone spec is used (config_source says
    so), the run stays within 10 % of the distance, the solution has its sigma columns, and
    the summary warns that the 30 arcmin mounting prior is too tight for the phone's 3.8 deg
    pitch mounting."""
    out = tmp_path / "r"
    r = _run("--json", "align", comma_bundle, "-m", "od-kf", "--init", "truth", "-o", out)
    assert r.exit_code == 0, r.output
    s = json.loads((out / "summary.json").read_text())
    src = s["info"]["config_source"]
    for k in ("gyro_drift_deg_h", "gyro_arw_deg_sqrt_h", "accel_bias_ug",
              "accel_vrw_ug_sqrt_hz", "gyro_markov_deg_h", "gyro_markov_tau_s"):
        assert src[k] == "meta.imu (assumed)", (k, src)
    assert s["config"]["gyro_markov_tau_s"] == 30.0
    e = s["errors"]
    assert e["final"]["horizontal_m"] < 0.10 * e["distance_m"], e["final"]
    assert any("od_mount_x" in w and "prior" in w for w in s["info"]["warnings"])
    sol = pd.read_csv(out / "solution.csv")
    sig = [c for c in sol.columns if c.startswith("sigma_")]
    assert {"sigma_phi_E", "sigma_phi_N", "sigma_phi_U", "sigma_vE", "sigma_north"} <= set(sig)
    assert np.isfinite(sol[sig].to_numpy()).all()


@needs_comma
def test_od_kf_with_a_wide_mounting_prior_does_not_warn_about_it(comma_bundle, tmp_path):
    out = tmp_path / "r"
    r = _run("--json", "align", comma_bundle, "-m", "od-kf", "--init", "truth", "-o", out,
             "--set", "mount_sigma_arcmin=300")
    assert r.exit_code == 0, r.output
    s = json.loads((out / "summary.json").read_text())
    assert not any("prior" in w for w in s["info"]["warnings"]), s["info"]["warnings"]
    # within 10 % of distance, the same sanity bound as the defaults' test above (the issue's
    # failure was 117 %); measured 48 m before the displacement rows gained their T^2/2 term
    # (a model fix shown on simulated truth, issue 15), 61 m after: written in the note
    assert s["errors"]["final"]["horizontal_m"] < 0.10 * s["errors"]["distance_m"]


def test_default_noise_on_a_real_log_without_spec_warns():
    """A real log without ``meta.imu``: the navigation-grade defaults are named in a
    warning (``aided_kf._warnings``)."""
    from inmotion.align.aided_kf import AidedKfConfig, config_with_spec

    cfg, src = config_with_spec(AidedKfConfig(), {"name": "real, no spec"})
    assert src["gyro_drift_deg_h"] == "default"

    class _F:                                      # the engine's counters, nothing isolated
        def counts(self):
            return {"odometer": {"used": 10, "rejected": 0}}

        def nis_sums(self):
            return {"odometer": (10.0, 10)}

    from inmotion.align.aided_kf import NS, _warnings
    res = {"states": np.zeros((1, NS + 6))}
    w = _warnings(_F(), ("odometer",), cfg, src, {"name": "x"}, res)
    assert len(w) == 1 and "navigation-grade" in w[0]
    assert _warnings(_F(), ("odometer",), cfg, src, {"simulated": True}, res) == []
