"""``inmotion import`` and ``inmotion export``: real logs in, results out in other formats.

::

    inmotion import FORMAT SOURCE -o BUNDLE [--mapping FILE] [-O key=value ...]
    inmotion export kf-gins RESULT -o FILE [--gps-week N]

``FORMAT`` is one of :data:`inmotion.io.importers.FORMATS` (``kf-gins``, ``comma2k19``,
``ems``, ``psins``, ``csv``); ``-O`` passes an importer option (``-O nav=truth.nav -O odo=odo.txt`` for
KF-GINS, ``-O order=4`` for cubic rate integration, ``-O gyro=gyro_uncalibrated`` for
comma2k19). Bad input (missing file, wrong layout, unknown format or option) raises
:class:`inmotion.errors.BadInput`, which the main command turns into exit status 2.
"""
from __future__ import annotations

import inspect
import json
from pathlib import Path

import click

from ..errors import BadInput

__all__ = ["import_cmd", "export_cmd", "parse_options"]

EXPORT_FORMATS = ("kf-gins", "ned-csv", "geojson")


def _value(text):
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return text


def parse_options(pairs, importer) -> dict:
    """``["key=value", ...]`` -> dict, checked against the importer's keyword options."""
    allowed = [p.name for p in inspect.signature(importer).parameters.values()
               if p.kind == inspect.Parameter.KEYWORD_ONLY]
    out = {}
    for pair in pairs:
        key, sep, val = pair.partition("=")
        key = key.strip()
        if not sep or not key:
            raise BadInput(f"option {pair!r} must be key=value")
        if key not in allowed:
            raise BadInput(f"unknown option {key!r} for this format; options: "
                           f"{', '.join(allowed) or 'none'}")
        out[key] = _value(val.strip())
    return out


def _group_flag(name) -> bool:
    """The main group's ``--json`` / ``--quiet`` (``ctx.obj`` of ``inmotion.cli.main``)."""
    ctx = click.get_current_context(silent=True)
    return bool(getattr(getattr(ctx, "obj", None), name, False))


def _summary(bundle, out) -> dict:
    import numpy as np
    sensors = [s for s in ("odometer", "radar", "ldv", "baro") if getattr(bundle, s) is not None]
    t = bundle.imu.t
    return {"bundle": str(out), "name": bundle.name, "imu_rows": int(len(t)),
            "imu_rate_hz": float(1.0 / np.median(np.diff(t))),
            "duration_s": float(t[-1] - t[0]), "sensors": sensors,
            "truth_rows": 0 if bundle.truth is None else int(len(bundle.truth.t)),
            "imu_gaps": len(bundle.meta.get("gaps", {}).get("imu", []))}


@click.command("import")
@click.argument("fmt", metavar="FORMAT")
@click.argument("source", type=click.Path())
@click.option("-o", "--output", "out", required=True, type=click.Path(), help="bundle folder")
@click.option("--mapping", type=click.Path(), default=None, help="YAML mapping (csv format)")
@click.option("-O", "--option", "options", multiple=True, metavar="KEY=VALUE",
              help="importer option, repeatable")
@click.option("--bundle-format", type=click.Choice(["csv", "parquet"]), default="csv",
              show_default=True)
@click.option("--json", "as_json", is_flag=True, help="print the summary as JSON")
@click.option("--quiet", is_flag=True)
def import_cmd(fmt, source, out, mapping, options, bundle_format, as_json, quiet):
    """Import a log in FORMAT (kf-gins, comma2k19, ems, psins, csv) from SOURCE into a bundle."""
    from ..io.bundle import write_bundle
    from ..io.importers import get_importer

    importer = get_importer(fmt)
    opts = parse_options(options, importer)
    if mapping is not None:
        if "mapping" not in inspect.signature(importer).parameters:
            raise BadInput(f"--mapping is only for the csv format, not {fmt!r}")
        opts["mapping"] = mapping
    bundle = importer(source, **opts)
    write_bundle(bundle, out, bundle_format)
    s = _summary(bundle, out)
    if as_json or _group_flag("json"):
        click.echo(json.dumps(s))
    elif not (quiet or _group_flag("quiet")):
        click.echo(f"{s['name']}: {s['imu_rows']} IMU rows at {s['imu_rate_hz']:.2f} Hz over "
                   f"{s['duration_s']:.1f} s; sensors: {', '.join(s['sensors']) or 'none'}; "
                   f"truth rows: {s['truth_rows']}; IMU gaps: {s['imu_gaps']} -> {out}")


@click.command("export")
@click.argument("fmt", metavar="FORMAT")
@click.argument("result", type=click.Path())
@click.option("-o", "--output", "out", required=True, type=click.Path(), help="file to write")
@click.option("--gps-week", type=int, default=0, show_default=True,
              help="GNSS week written in column 1")
@click.option("--quiet", is_flag=True)
def export_cmd(fmt, result, out, gps_week, quiet):
    """Export a RESULT folder's solution in FORMAT: kf-gins (an 11-column .nav file), ned-csv
    (NED / FRD table with its convention in the header, :mod:`inmotion.io.export`) or geojson
    (the track for a map)."""
    from ..io.export import EXPORTERS
    from ..io.importers.kf_gins import export_kf_gins

    fmt = str(fmt).lower().replace("_", "-")
    if fmt not in EXPORT_FORMATS:
        raise BadInput(f"unknown export format {fmt!r}; choose from {', '.join(EXPORT_FORMATS)}")
    if fmt in EXPORTERS:
        path = EXPORTERS[fmt](result, out)
    else:
        src = result
        if (Path(result) / "summary.json").is_file():    # CSV or Parquet result folder
            from ..io.result import read_result
            src = read_result(result)
        path = export_kf_gins(src, out, gps_week=gps_week)
    if not (quiet or _group_flag("quiet")):
        click.echo(f"wrote {path}")
