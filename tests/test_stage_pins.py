"""The stages that ran before the rear trim (the sixty-eighth stage) are rerun as they ran: a car described is never
trimmed to the drive there (tuning.real.BEFORE_69), while the trim is what ships for every command."""

from __future__ import annotations

from pathlib import Path

import pytest

from roadbank.tuning.real import (choose_described_filter, choose_described_ratio, choose_gate_speed,
                                  choose_smoother_gate, simulated_sets, training_logs)
from roadbank.vehicle import QUIET_FILTER, QUIET_RATIO, conditions, factory

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


@pytest.fixture
def trims(monkeypatch):
    """The trim setting in force at each call of the trim of a car described (roadbank.vehicle.factory.rear_trim)."""
    seen = []
    real = factory.rear_trim

    def spy(*args, **kwargs):
        seen.append(conditions.REAR_TRIM)
        return real(*args, **kwargs)
    monkeypatch.setattr(factory, "rear_trim", spy)
    return seen


@pytest.fixture(scope="module")
def few():
    """Two simulated training drives of each shipped car."""
    return [drives[:2] for drives in simulated_sets()]


def test_the_trim_ships_for_a_car_described(trims, few):
    """The control: building the default for a car described trims it (the setting in force is the shipped one)."""
    from roadbank.vehicle import for_log, load_vehicle

    for_log("kinematic-pif", few[1][0].signals, vehicle=load_vehicle("sedan"))
    assert trims == [conditions.REAR_TRIM] and conditions.REAR_TRIM


@pytest.mark.parametrize("stage", ["seventh", "fifteenth"])
def test_the_described_cars_stages_never_trim(trims, few, stage):
    if stage == "seventh":
        choose_described_ratio(few, ratios=(QUIET_RATIO,))
    else:
        choose_described_filter(few, filters=(QUIET_FILTER,))
    assert len(trims) == sum(map(len, few)) and not any(trims)


def test_the_offline_gates_stages_never_trim(trims, few):
    """The sixty-fourth and sixty-fifth stages (the sixty-seventh shares the sixty-fifth's scores) on one training
    drive and the simulated drives: every car described is read untrimmed."""
    if not training_logs(DATA):
        pytest.skip(f"no KITTI training drive under {DATA}")
    logs = training_logs(DATA)[:1]
    kept = [s for s, _, _ in training_logs(DATA, roll_rate=True)[:1]]
    choose_smoother_gate(logs, few, few, kept, few)
    choose_gate_speed(logs, few, few, speeds=(0.0,))
    assert trims and not any(trims)
