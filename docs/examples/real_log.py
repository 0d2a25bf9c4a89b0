"""Worked example 2: import a real log and run a method on it.

The comma2k19 segment (60 s on a highway: a phone IMU, CAN-bus speed, a reference pose from
the data set's processing) is imported into a bundle, written to ``OUTDIR/bundle`` and read
back, and dead reckoning (``dr``: gyro attitude + the CAN speed as the odometer) runs from the
reference pose at the first IMU epoch. The result is compared with the reference, written to
``OUTDIR/dr`` and exported as GeoJSON for a map.

The data folder is ``--data DIR``, else ``$INMOTION_REAL_DATA``, else ``shared/data/real``
found from the working directory upwards (the project's layout). Without it the script says
so and exits with status 0 (the test skips).

Run: ``python docs/examples/real_log.py OUTDIR [--data DIR]``.
"""
import argparse
from pathlib import Path

from inmotion import registry
from inmotion.core.solution import NavState
from inmotion.core.metrics import error_series, errors_block, interpolate_truth
from inmotion.reproductions.real import default_data_root
from inmotion.io.bundle import read_bundle, write_bundle
from inmotion.io.export import export_geojson
from inmotion.io.importers import import_log
from inmotion.io.result import write_result

DRIVE = "comma2k19_rav4_60s"


def main(out_dir, data=None):
    root = Path(data) if data else default_data_root()
    source = root / DRIVE
    if not source.is_dir():
        print(f"no real data at {source}; give --data DIR or set INMOTION_REAL_DATA")
        return None
    out = Path(out_dir)
    write_bundle(import_log("comma2k19", source), out / "bundle")
    bundle = read_bundle(out / "bundle")              # validated, as the CLI reads it
    t0 = float(bundle.imu.t[0])
    ref = interpolate_truth(bundle.truth, [t0])
    init = NavState.from_euler(t0, ref.lat[0], ref.lon[0], ref.h[0], ref.vel_n[0],
                               ref.euler[0])
    run, Config = registry.get("dr").load()
    sol = run(bundle, Config(sensor="odometer"), init)
    block = errors_block(error_series(sol, bundle.truth))
    write_result(sol, out / "dr", truth=bundle.truth)
    export_geojson(out / "dr", out / "dr.geojson")
    f = block["final"]
    print(f"{bundle.name}: {block['duration_s']:.1f} s, {block['distance_m'] / 1000:.2f} km; "
          f"dead reckoning ends {f['horizontal_m']:.1f} m from the reference "
          f"({100 * f['horizontal_m'] / block['distance_m']:.2f} % of distance), "
          f"heading error {f['yaw_arcmin']:.1f} arcmin")
    return block


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out_dir")
    p.add_argument("--data", default=None, help="folder of the real drives")
    a = p.parse_args()
    main(a.out_dir, a.data)
