"""Run a benchmark script with the length row's experiment knobs and configuration defaults
(issue 15, h15nees5)::

    PYTHONPATH=src:tests python benchmarks/with_length_knobs.py MEAN_MODE VAR_SCALE DEFAULTS_JSON SCRIPT [ARGS..]

``MEAN_MODE`` 0: the second order's mean in the innovation (the code's), 1: not;
``VAR_SCALE``: its variance times this (``aided_kf.LENGTH_MEAN_MODE``, ``LENGTH_VAR_SCALE``), or
``memory`` / ``memory:N``: times the intervals the filter has combined since its start, at most
``N`` (``aided_kf.LENGTH_MEMORY_MAX``, helper h15nees6), or ``walk:Q[:N]``: a random walk of
``Q`` ppm / sqrt(s) on the scale state with the variance ``N`` times (default 1,
``aided_kf.LENGTH_SCALE_WALK``);
``DEFAULTS_JSON`` becomes the field defaults of the paper 003 filters' configurations (as
``benchmarks/default_checks.py`` does), e.g. ``'{"exact_attitude_columns": true,
"second_order_length": true}'``.
"""
import json
import runpy
import sys

from inmotion.align import aided_kf as ak

ak.LENGTH_MEAN_MODE = int(sys.argv[1])
if sys.argv[2].startswith("memory"):
    ak.LENGTH_MEMORY_MAX = float(sys.argv[2].partition(":")[2] or "inf")
elif sys.argv[2].startswith("walk:"):
    walk, _, scale = sys.argv[2][5:].partition(":")
    ak.LENGTH_SCALE_WALK = float(walk)
    ak.LENGTH_VAR_SCALE = float(scale or 1.0)
else:
    ak.LENGTH_VAR_SCALE = float(sys.argv[2])
for cls in (ak.NhcKfConfig, ak.AidedKfConfig, ak.FkfConfig):
    for name, value in json.loads(sys.argv[3]).items():
        if name in cls.model_fields:
            cls.model_fields[name].default = value
    cls.model_rebuild(force=True)
sys.argv = sys.argv[4:]
runpy.run_path(sys.argv[0], run_name="__main__")
