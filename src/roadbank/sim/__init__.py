"""roadbank.sim: a nonlinear vehicle plant, roads, drivers, ESP sensors and the paper's scenarios.

Quick start::

    from roadbank.sim import run_scenario, SCENARIOS, CONDITIONS_BY_SCENARIO
    res = run_scenario("const-bank", condition="cf120", seed=1)
    res.signals      # roadbank.Signals at 100 Hz (t, vx, ay, r, delta_f)
    res.truth.phi_b  # truth bank (rad) from the contact-point heights

Modules: :mod:`.params` (PlantParams, TyreParams), :mod:`.tyres` (Magic Formula),
:mod:`.plant` (the compiled right-hand side ``f(x, u, road, params)``),
:mod:`.road` (banked roads and the test track), :mod:`.driver`, :mod:`.integrate`
(RK4 loop), :mod:`.sensors`, :mod:`.scenarios`. See docs/simulator.md.
"""

from .driver import Driver
from .params import PlantParams, TyreParams
from .road import Road, flat_road, straight_road, test_track, two_lane_road
from .scenarios import (CONDITIONS, CONDITIONS_BY_SCENARIO, SCENARIOS, Condition, Scenario, SimResult, Truth,
                        measure_realtime_factor, run, run_scenario, trim_state)
from .sensors import ChannelErrorModel, SensorConfig

#: the former name of :class:`ChannelErrorModel`, kept for code that imports it
ChannelSpec = ChannelErrorModel

__all__ = ["CONDITIONS", "CONDITIONS_BY_SCENARIO", "SCENARIOS", "ChannelErrorModel", "ChannelSpec", "Condition",
           "Driver",
           "PlantParams", "Road", "Scenario", "SensorConfig", "SimResult", "Truth", "TyreParams",
           "flat_road", "measure_realtime_factor", "run", "run_scenario", "straight_road", "test_track",
           "trim_state", "two_lane_road"]
