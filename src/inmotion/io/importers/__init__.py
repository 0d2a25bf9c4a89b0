"""Importers: logs in the formats other tools write -> :class:`inmotion.core.bundle.Bundle`.

One module per format, each ``import_<fmt>(source, **options) -> Bundle`` in SI and the DESIGN
frames, with the source's axes declared as a constant (see :mod:`.axes`), never guessed:

=============  ==========================================  ====================================
format         source                                      module
=============  ==========================================  ====================================
``kf-gins``    KF-GINS / OB_GINS IMU text file (+ files)   :mod:`.kf_gins` (and the export)
``comma2k19``  a comma2k19 segment folder                  :mod:`.comma2k19`
``ems``        the EMS-SymINSGNSS MATLAB file              :mod:`.ems`
``psins``      PSINS ``.imu`` counts log or transfer ``.mat``  :mod:`.psins`
``csv``        any CSV, with a YAML mapping                :mod:`.csv` (``docs/importers.md``)
=============  ==========================================  ====================================

:func:`import_log` picks the importer by name; an unknown name is bad input.
"""
from __future__ import annotations

import importlib

from ...errors import BadInput

__all__ = ["FORMATS", "import_log", "get_importer"]

#: format name -> "module:function" (imported on use)
FORMATS = {
    "kf-gins": "inmotion.io.importers.kf_gins:import_kf_gins",
    "comma2k19": "inmotion.io.importers.comma2k19:import_comma2k19",
    "ems": "inmotion.io.importers.ems:import_ems",
    "psins": "inmotion.io.importers.psins:import_psins",
    "csv": "inmotion.io.importers.csv:import_csv",
}


def get_importer(fmt: str):
    """The importer function of format ``fmt`` (``kf_gins`` and ``kf-gins`` both work)."""
    key = str(fmt).strip().lower().replace("_", "-")
    if key not in FORMATS:
        raise BadInput(f"unknown import format {fmt!r}; choose from {', '.join(FORMATS)}")
    mod, _, fn = FORMATS[key].partition(":")
    return getattr(importlib.import_module(mod), fn)


def import_log(fmt: str, source, **options):
    """``get_importer(fmt)(source, **options)``: the log as a Bundle."""
    return get_importer(fmt)(source, **options)
