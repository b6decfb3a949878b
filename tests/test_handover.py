"""A log designed quiet whose roads turn loud is handed to the design of its first loud minute (estimators.HandOver,
vehicle.conditions.ROAD_CHANGE: the fifty-eighth stage).

Truth: simulated drives (the true bank known) on one clock, six on a data sheet's sensors (quiet) and then six with
0.5 m/s^2 of white noise added to ay (a shaking accelerometer: loud); the same log without the loud part; and the
estimators' own contracts (a run in chunks and sample by sample give the whole run's outputs)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadbank import estimators
from roadbank.estimators import HandOver
from roadbank.signals import Signals
from roadbank.tuning.real import design_settings, simulated_sets
from roadbank.tuning.real.roads import on_one_clock
from roadbank.vehicle import for_log, load_vehicle
from roadbank.vehicle.conditions import ROAD_CHANGE, ROAD_CHECK_WINDOW_S

LOUD_AY = 0.5       # m/s^2, white
SEDAN = load_vehicle("sedan")


def built(name, log):
    """``name`` as ``roadbank estimate --vehicle sedan`` builds it for ``log``: the simulated drives' car, described
    (a quiet log of a car nobody described is designed loud and never handed over: the sixty-second stage)."""
    return for_log(name, log, vehicle=SEDAN)


@pytest.fixture(scope="module")
def quiet_then_loud():
    """``(log, true bank rad, first row of the loud part)``."""
    drives = simulated_sets(cars=("sedan",), n=12)[0]
    rng = np.random.default_rng(1)
    loud = [Signals(d.signals.t, d.signals.vx, d.signals.ay + LOUD_AY * rng.standard_normal(len(d.signals)),
                    d.signals.r, d.signals.delta_f) for d in drives[6:]]
    log, starts = on_one_clock([d.signals for d in drives[:6]] + loud, 0.1)
    return log, np.concatenate([d.phi_b for d in drives]), starts[6]


def _bank_rms_deg(est, bank, rows):
    return float(np.degrees(np.sqrt(np.mean((est.phi_b[rows] - bank[rows]) ** 2))))


def test_the_shipped_setting_hands_over():
    assert ROAD_CHANGE is True


def test_a_log_whose_roads_turn_loud_is_handed_over_when_the_first_loud_stretch_closes(quiet_then_loud):
    log, bank, loud_row = quiet_then_loud
    est = built("kinematic-pif", log)
    assert isinstance(est, HandOver) and isinstance(est.inner, estimators.PIFAdaptive)     # designed quiet
    out = est.run(log)
    # the loud part begins inside the third stretch of 60 s: the first wholly loud one closes at 180 s
    assert log.t[loud_row] < 2 * ROAD_CHECK_WINDOW_S + 1.0
    j = int(np.searchsorted(log.t, est.handed_at))
    assert log.t[j - 1] < 3 * ROAD_CHECK_WINDOW_S <= est.handed_at
    assert isinstance(est.handed_to, estimators.KinematicPIF) and est.handed_to.name == "kinematic-pif"
    with design_settings(road_change=False):
        before = built("kinematic-pif", log)
        once = before.run(log)
    assert not isinstance(before, HandOver)
    assert np.array_equal(out.theta[:j], once.theta[:j])                # causal: nothing changes before it
    after = np.flatnonzero((np.arange(len(log)) >= j) & (log.vx >= 5.0) & out.valid & once.valid)
    # the car's model on a shaking accelerometer against the blend designed for it (measured 1.11 and 0.48 deg)
    assert _bank_rms_deg(out, bank, after) < 0.6 * _bank_rms_deg(once, bank, after)


def test_a_log_whose_roads_stay_quiet_is_not_handed_over(quiet_then_loud):
    log, _, loud_row = quiet_then_loud
    quiet = log[:loud_row]
    est = built("kinematic-pif", quiet)
    out = est.run(quiet)
    assert math.isnan(est.handed_at) and est.handed_to is None
    assert np.array_equal(out.theta, est.inner.run(quiet).theta)


@pytest.mark.parametrize("rows", [97, 1000, 7001])
def test_chunks_and_steps_give_the_whole_run(quiet_then_loud, rows):
    log = quiet_then_loud[0]
    whole = built("kinematic-pif", log)
    ref = whole.run(log)
    est = built("kinematic-pif", log)
    parts = [est.run(log[a:a + rows], reset=a == 0) for a in range(0, len(log), rows)]
    assert np.array_equal(np.concatenate([p.theta for p in parts]), ref.theta)
    assert np.array_equal(np.concatenate([p.valid for p in parts]), ref.valid)
    assert est.handed_at == whole.handed_at
    assert all(set(p.states) == set(parts[0].states) for p in parts)        # the same columns in every chunk
    if rows == 1000:
        stepper = built("kinematic-pif", log)
        theta = np.array([stepper.step(log.t[i], log.vx[i], log.ay[i], log.r[i], log.delta_f[i]).theta
                          for i in range(len(log))])
        assert np.array_equal(theta, ref.theta) and stepper.handed_at == whole.handed_at


@pytest.mark.parametrize("fault", ["nan", "repeated", "back"])
def test_a_bad_stamp_sample_by_sample_neither_fails_nor_moves_the_hand_over(quiet_then_loud, fault):
    """A NaN, repeated or backward stamp stepped in the middle of a stretch (the bare estimator takes each) belongs to
    the stretch before it, as in one run: the log is handed over where the whole run of it hands over (it raised a
    ValueError from the stretch's samples, or with a stamp back by 50 s split the stretch and handed over 60 s
    late)."""
    log = quiet_then_loud[0]
    whole = built("kinematic-pif", log)
    whole.run(log)
    j = int(np.searchsorted(log.t, 150.0))
    stamps = {"nan": [math.nan], "repeated": [log.t[j], log.t[j]], "back": [log.t[j] - 50.0]}[fault]
    est = built("kinematic-pif", log)
    for i in range(len(log)):
        for t in stamps if i == j else [log.t[i]]:
            est.step(t, log.vx[i], log.ay[i], log.r[i], log.delta_f[i])
    assert est.handed_at == whole.handed_at


def test_a_nan_stamp_where_a_stretch_begins_hands_over_at_the_next_stamp(quiet_then_loud):
    log = quiet_then_loud[0]
    whole = built("kinematic-pif", log)
    whole.run(log)
    j = int(np.searchsorted(log.t, whole.handed_at))
    est = built("kinematic-pif", log)
    for i in range(len(log)):
        est.step(math.nan if i == j else log.t[i], log.vx[i], log.ay[i], log.r[i], log.delta_f[i])
    assert est.handed_at == log.t[j + 1]             # it was NaN: no hand-over said


def test_chunks_that_overlap_are_read_as_the_log(quiet_then_loud):
    log = quiet_then_loud[0]
    whole = built("kinematic-pif", log)
    whole.run(log)
    est = built("kinematic-pif", log)
    est.run(log[:15000])
    est.run(log[14990:], reset=False)                # ten samples again
    assert est.handed_at == whole.handed_at


def test_repr_says_the_estimator_in_charge(quiet_then_loud):
    log = quiet_then_loud[0]
    est = built("kinematic-pif", log)
    assert "handed to" not in repr(est)
    est.run(log)
    assert repr(est.handed_to) in repr(est) and f"{est.handed_at:.6g} s" in repr(est)     # it named pif-adaptive alone


def test_reset_forgets_the_hand_over(quiet_then_loud):
    log, _, loud_row = quiet_then_loud
    est = built("kinematic-pif", log)
    est.run(log)
    assert est.handed_to is not None
    est.run(log[:loud_row])                          # reset=True: a new log
    assert est.handed_to is None and math.isnan(est.handed_at)


def test_behind_the_offset_learner_and_offline_estimators(quiet_then_loud):
    log = quiet_then_loud[0]
    learnt = estimators.with_online_offsets(built("kinematic-pif", log))
    learnt.run(log)
    assert math.isfinite(learnt.handed_at)               # the learner in front, the hand-over behind it
    assert not isinstance(built("kinematic-smoother", log), HandOver)      # offline: roadbank map warns instead
    with design_settings(road_change="esp"):
        assert isinstance(built("kinematic-pif", log), HandOver)            # no roll rate: as True


def test_a_bad_stretch_reader_or_stretch_is_refused():
    with pytest.raises(TypeError, match="HandOver expects a roadbank estimator"):
        HandOver(object(), lambda s: None, lambda **c: None)
    with pytest.raises(ValueError, match="stretch_s must be > 0"):
        HandOver(estimators.make("pif-adaptive"), lambda s: None, lambda **c: None, stretch_s=0.0)


def test_a_held_log_is_read_at_its_source_and_handed_over(quiet_then_loud):
    """Its 25 Hz frames held onto the 100 Hz grid (a logger's hold; at 10 Hz the quiet part's white noise, sampled
    without an anti-alias filter, reads loud): read at the frames' rate (AtSource, outermost) and handed over at the
    same stretch's end as the frames themselves."""
    log = quiet_then_loud[0]
    frames = log.take(np.arange(0, len(log), 4))
    held = Signals(log.t, *(np.repeat(getattr(frames, c), 4)[:len(log)] for c in ("vx", "ay", "r", "delta_f")))
    est = built("kinematic-pif", held)
    assert isinstance(est, estimators.AtSource) and isinstance(est.inner, HandOver)
    learnt = estimators.with_online_offsets(est)
    assert isinstance(learnt, estimators.AtSource) and isinstance(learnt.inner.inner, HandOver)
    out = est.run(held)
    own = built("kinematic-pif", frames)
    own.run(frames)
    assert est.inner.handed_at == own.handed_at
    assert np.isfinite(out.theta).all()


def test_estimate_says_what_it_handed_over_to():
    from roadbank.vehicle.conditions import handed_over_warnings

    gyro, = handed_over_warnings("log.csv", {"kinematic-pif": (130.5, estimators.make("kinematic-gyro"))}, 10.0)
    blend, = handed_over_warnings("log.csv", {"kinematic-pif": (130.5, estimators.make("kinematic-pif"))}, 10.0)
    assert "from 120.5 s on kinematic-pif is kinematic-gyro, the gyro-aided filter" in gyro
    assert "from 120.5 s on kinematic-pif is the low-pass blend" in blend and "pif-adaptive" in blend


def test_the_stretch_floor_read_alone_is_the_conditions_floor(quiet_then_loud):
    """The hand-over reads a stretch's ay floor alone first (vehicle.conditions.quiet_floor_of) and its whole
    conditions only where that reads loud: the same number as log_conditions' log_ay_floor, quiet or loud, held too."""
    from roadbank.vehicle.conditions import log_conditions, quiet_floor_of

    log = quiet_then_loud[0]
    frames = log.take(np.arange(0, len(log), 4))
    held = Signals(log.t, *(np.repeat(getattr(frames, c), 4)[:len(log)] for c in ("vx", "ay", "r", "delta_f")))
    for s in (log, held):
        for a in range(0, len(s), 6000):
            part = s[a:a + 6000]
            alone, whole = quiet_floor_of(part), log_conditions(part)["log_ay_floor"]
            assert alone == whole or (math.isnan(alone) and math.isnan(whole))      # (a short tail: none)
    assert np.isfinite(quiet_floor_of(log[:6000]))


@pytest.fixture(scope="module")
def loud_quiet_loud():
    """``log``: six simulated sedan drives with a shaking accelerometer, six as simulated, the first six again."""
    drives = simulated_sets(cars=("sedan",), n=12)[0]
    rng = np.random.default_rng(1)
    loud = [Signals(d.signals.t, d.signals.vx, d.signals.ay + LOUD_AY * rng.standard_normal(len(d.signals)),
                    d.signals.r, d.signals.delta_f) for d in drives[:6]]
    log, starts = on_one_clock(loud + [d.signals for d in drives[6:]] + loud, 0.1)
    return log, log.t[starts[6]], log.t[starts[12]]


def test_the_shipped_setting_hands_one_way(loud_quiet_loud):
    """The sixty-first stage kept the hand-over one way (ROAD_CHANGE_BACK False): a log designed loud is not read on."""
    from roadbank.vehicle.conditions import ROAD_CHANGE_BACK

    assert ROAD_CHANGE_BACK is False
    est = built("kinematic-pif", loud_quiet_loud[0])
    assert isinstance(est, estimators.KinematicPIF) and not isinstance(est, HandOver)


def test_the_candidate_hands_back_where_the_roads_turn_quiet_and_over_again(loud_quiet_loud):
    """The stage's candidate B (ROAD_CHANGE_BACK True): the blend designed on the loud first minute hands to the car's
    model when the first wholly quiet stretch closes (the quiet part begins in the third stretch: at 180 s), which
    hands over again when the first wholly loud stretch after it closes (at 300 s); one run, chunks and steps agree."""
    log, quiet_at, loud_at = loud_quiet_loud
    assert 2 * ROAD_CHECK_WINDOW_S < quiet_at + 60.0 and loud_at < 5 * ROAD_CHECK_WINDOW_S
    with design_settings(road_change_back=True):
        est = built("kinematic-pif", log)
        whole = est.run(log)
        assert isinstance(est, HandOver) and isinstance(est.inner, estimators.KinematicPIF)
        back = est.handed_to
        assert isinstance(back, HandOver) and isinstance(back.inner, estimators.PIFAdaptive)
        assert 3 * ROAD_CHECK_WINDOW_S <= est.handed_at < 3 * ROAD_CHECK_WINDOW_S + 0.1
        assert isinstance(back.handed_to, HandOver) and isinstance(back.handed_to.inner, estimators.KinematicPIF)
        assert 5 * ROAD_CHECK_WINDOW_S <= back.handed_at < 5 * ROAD_CHECK_WINDOW_S + 0.1
        chunked = built("kinematic-pif", log)
        parts = [chunked.run(log[a:a + 997], reset=a == 0).theta for a in range(0, len(log), 997)]
        stepper = built("kinematic-pif", log)
        stepped = [stepper.step(log.t[i], log.vx[i], log.ay[i], log.r[i], log.delta_f[i]).theta
                   for i in range(len(log))]
    assert np.array_equal(np.concatenate(parts), whole.theta)
    assert np.array_equal(np.array(stepped), whole.theta)
    assert not isinstance(built("kinematic-smoother", log), HandOver)     # offline: never


def test_a_stretch_reads_quiet_as_a_first_minute_would(loud_quiet_loud):
    """quiet_stretch gives a stretch's conditions where they would keep the car's model (is_quiet, keeps_cars_model) and
    it drives 30 s or more; None on a loud stretch, on one that drives less, and where an INS's roll rate is read."""
    import dataclasses

    from roadbank.vehicle import SensorSpec, log_conditions
    from roadbank.vehicle.conditions import is_quiet, quiet_stretch

    log, quiet_at, loud_at = loud_quiet_loud
    quiet = log[int(np.searchsorted(log.t, quiet_at)):int(np.searchsorted(log.t, quiet_at + 60.0))]
    loud = log[:int(np.searchsorted(log.t, 60.0))]
    c = quiet_stretch(quiet, sensors=SensorSpec())
    assert c == log_conditions(quiet) and is_quiet(SensorSpec(), c["log_rate"], c["log_ay_noise"],
                                                   log_ay_floor=c["log_ay_floor"])
    assert quiet_stretch(loud, sensors=SensorSpec()) is None
    assert quiet_stretch(quiet[:int(np.searchsorted(quiet.t, quiet.t[0] + 20.0))], sensors=SensorSpec()) is None
    roll = (quiet.ay - quiet.vx * quiet.r) / 9.81          # a roll rate that follows the roll ay shows, an INS's
    ins = dataclasses.replace(quiet, p=np.gradient(roll, quiet.t), unbiased=frozenset({"p"}))
    c = log_conditions(ins)
    assert c["log_gyro_unbiased"] and 0.5 <= c["log_roll_rate"] <= 2.0
    assert quiet_stretch(ins, sensors=SensorSpec()) is None
    assert quiet_stretch(dataclasses.replace(ins, unbiased=frozenset()), sensors=SensorSpec()) is not None  # a phone's


def test_a_quiet_log_of_a_car_nobody_described_is_designed_loud_and_not_handed_over(quiet_then_loud):
    """The sixty-second stage (UNDESCRIBED_KEEPS_MODEL False): without a vehicle file the quiet log is designed as a
    loud one, the low-pass blend, which it stays (nothing to hand over); the design line says why; with the car
    described (or the fitted car read as described) it keeps the car's model until its roads turn loud."""
    from roadbank.fleet.process import design_words
    from roadbank.vehicle import car_for_log, log_conditions
    from roadbank.vehicle.conditions import UNDESCRIBED_KEEPS_MODEL

    log = quiet_then_loud[0]
    assert UNDESCRIBED_KEEPS_MODEL is False
    est = for_log("kinematic-pif", log)
    assert isinstance(est, estimators.KinematicPIF) and not isinstance(est, HandOver)
    assert isinstance(for_log("kinematic-pif", log, described=True).inner, estimators.PIFAdaptive)
    with design_settings(undescribed_keeps_model=True):
        assert isinstance(for_log("kinematic-pif", log).inner, estimators.PIFAdaptive)
    # the map's offline smoother likewise (the sixty-third stage): the low-pass smoother, pif-smoother with the car
    assert isinstance(for_log("kinematic-smoother", log).inner, estimators.KinematicSmoother)   # gated (64th)
    assert isinstance(built("kinematic-smoother", log), estimators.PIFSmoother)
    cond = log_conditions(log)
    _, nobody = car_for_log(log, cond)
    _, file = car_for_log(log, cond, vehicle=SEDAN)
    assert nobody["quiet"] and file["quiet"]
    assert design_words(nobody, "kinematic-pif").endswith(
        "so kinematic-pif is the low-pass blend (a quiet log, but the car's model is kept only for a car described: "
        "a vehicle file, --vehicle; roadbank identify writes one from logs with a steering angle)")
    assert "so kinematic-pif is pif-adaptive until its roads turn loud" in design_words(file, "kinematic-pif")
