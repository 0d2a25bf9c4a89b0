"""inmotion.sim: the drive simulator (scenario YAML -> truth, exact IMU increments, sensors).

``simulate(scenario, rng) -> Bundle`` and ``load_scenario`` are the entry points; see
``docs/scenarios.md`` for the scenario schema and :mod:`inmotion.sim.trajectory` for how the
truth is made consistent with the navigation equations.
"""
from .scenario import find_scenario, load_scenario
from .simulate import simulate, simulate_truth

__all__ = ["simulate", "simulate_truth", "load_scenario", "find_scenario"]
