r"""The first to twenty-third stages of :mod:`roadbank.tuning.real`: the default on the ESP channels (``kinematic-lp``,
``kinematic-ff``, the blend ``kinematic-pif`` and its gate, the road noise, the quiet log, the car of an undescribed
log, the offline smoother).

**The default estimator and the gate of** ``kinematic-pif`` follow the priority of real roads: where
real roads and simulated drives pull apart, the error on real drives is what a user gets. So the
candidates (the causal estimators, and ``kinematic-pif`` over the gate grid :data:`GATE_GRID`) are
ranked by the real-road median alone; among those within :data:`TIE_DEG` of the best, the lowest
simulated median wins (:func:`choose_by_roads`). The low-pass constants above keep the sum: a
standalone low-pass must not lose to the raw kinematic estimate on simulated cars.

``kinematic-pif``'s low-pass is scheduled on the log's noise
(:func:`roadbank.estimators.lowpass.cutoff_for_noise`), with a root-mean-square bank rate of roads
as its one prior. Its constants are chosen by the same real-roads-first rule in two stages, each
over a fixed grid: first the bank rate (:data:`BANK_RATES_DEG`) and ``kappa`` (:data:`KAPPAS`)
with the gate held at its value, then the gate (:data:`GATE_GRID`) at the chosen pair
(:func:`kinematic_pif_candidates`). Both stages ran before the third existed (``quiet_ratio=0``).
The third stage chose, by the same rule, on which logs the blend gives way to the car's model
throughout (then the default PIF): those whose ``ay`` road noise is at most ``quiet_ratio`` times
the data sheet's (:func:`roadbank.vehicle.is_quiet`), over :data:`QUIET_RATIOS`; exact ties go to
the smaller ratio (fewer logs leave the low-pass). It chose 1.5. The fourth stage chooses, at
that ratio and by the same rule, the filter of a quiet log over :data:`QUIET_FILTERS` (exact ties
go to the earlier one); it chose ``pif-adaptive``. The fifth stage chooses the lowest speed of the
blend (:data:`V_MINS`): the kinematic estimate holds at any speed (a car at rest on a bank reads
``ay = g sin theta``) and the low-pass need not restart after every stop.

The stages first ran with a warm-up after each start
(:data:`~roadbank.validation.kitti.KITTI_SCORING_EACH_START`), which leaves out the seconds after
each stop; the fifth first ran with a warm-up once from the first sample at speed. The real-road
target is stated with the warm-up the drive's first 5 s (its medians on the 16 shared drives, the
kinematic estimate's 0.91 deg and a 0.3 Hz low-pass's 0.38, are those of that scoring: 0.912 and
0.380; with a warm-up after each start 0.927 and 0.362), so every stage was run again with it
(:data:`~roadbank.validation.kitti.KITTI_SCORING`), in order, the lowest speed at 1 m/s until the
fifth: the low-pass constants, the bank rate, the gate, the quiet ratio and the quiet filter are
the same; ``kappa`` became 0.2 (first 0.3); the lowest speed stayed 1 m/s (3, 2 and 1 m/s tie on the
real drives within 0.0003 deg and on the simulated ones, which never slow down, to float rounding, which
first decided for 3 m/s; :func:`choose_by_roads` counts that as equal, :data:`EQUAL_DEG`, and the real
median decides).
The sixth stage, run after the fifth with the same scoring, chooses the low-pass's sampled-data lead
(:data:`LEADS_SAMPLES`, in sample intervals of the log; :mod:`roadbank.estimators.lowpass`): it chose
half an interval, the lag of the first-order filter of the samples (KITTI training median 0.4068 ->
0.3929 deg). The stages before it ran without a lead and were not run again. The seventh
(:func:`choose_described_ratio`) chooses the quiet ratio for a car that is described, on the simulated
drives built for their own car: it chose 6 while the noise was measured from 1 Hz on every log.

The noise is now measured above the vehicle's dynamics band as far as the log reaches
(:func:`roadbank.signals.noise_band_hz`: 3 Hz on a 100 Hz log, 1 Hz on a 10 Hz one as before); from
1 Hz, the simulated drives' hard manoeuvres had read as up to 6 times the data sheet's noise. Every
stage was run again in order with it. The KITTI drives (10 Hz) measure as before, so every real-road
median is the same; the first six stages chose the same; the seventh ties from 1.5 up (every
simulated drive now reads 0.93-1.13 times its data sheet) and so chose 1.5, the ratio of a car
nobody described: one quiet ratio, :data:`roadbank.vehicle.QUIET_RATIO`, for every car.

The eighth stage chooses how a log whose car is not described picks its design car among the shipped
ones (:func:`roadbank.vehicle.design_car`: the car whose default estimate of the log's first minute is
smoothest, where it beats the static sedan by a margin), over :data:`CAR_MARGINS` (``inf``: always the
sedan, as the stages before it ran): 1.25. Every KITTI training drive keeps the sedan (the real medians
tie); the simulated drives of the four cars, not described, go 0.3199 -> 0.2569 deg.

The ninth stage (:func:`choose_quiet_measure`) chooses what the quiet decision reads: the road noise over
the design span, as before, or its noise floor, the median over 4 s windows
(:data:`QUIET_MEASURES`). On every training drive the two give the same estimate (each KITTI drive is loud
by both, each simulated one quiet by both: 0.392932 and 0.256915 deg), so the rule breaks the tie on a
third set of simulated drives, the paper's five scenarios for the four cars (:func:`paper_sets`, three
noise seeds; median theta RMS after 5 s), which the split leaves out of both validation sets: the floor,
0.472 -> 0.355 deg (the S-curve at the tyres' limit read loud by its mean).

The tenth stage (``kinematic_pif_candidates(10)``) chooses the limit of the blend's low-pass update, in
standard deviations of the kinematic estimate's designed noise (:data:`CLIPS`; 0: linear, as every stage
before ran; :func:`roadbank.estimators.kernels.sample.limited_ay`): road vibration is heavy-tailed. It chose 3
(KITTI training median 0.3929 -> 0.3853 deg; every simulated training drive is quiet, so they tie).
The eleventh (:func:`smoother_clip_candidates`) chooses the same for both passes of the offline
``kinematic-smoother``: 2.5 (0.2168 -> 0.2082 deg).

The twelfth stage (:func:`choose_noise_tau`) chooses the time constant of the running noise estimate that the
blend's limited low-pass follows (:data:`NOISE_TAUS`; 0: the design span's noise throughout, as every stage
before ran; :func:`roadbank.estimators.kernels.sample.noise_update`): a long drive changes roads after the
minute it is designed on. Its objective adds to the KITTI training median that of the same drives put end to
end in both orders (:func:`long_logs`, :func:`long_median`), a long drive starting on either end of them. It
chose 60 s: drives one by one 0.3853 -> 0.3867 deg, end to end 0.4084 -> 0.3884 (in order 0.3886 -> 0.3871,
reversed 0.4084 -> 0.3899); the simulated training drives are quiet and do not take part. The thirteenth
(``choose_noise_tau(..., stage=13)``, the same objective) chooses the time constant of a second, shorter ratio
that the limit alone reads (:data:`LIMIT_TAUS`; 0: the gain's ratio, as the stages before ran): 8 s (0.3867 ->
0.3847 one by one, 0.3884 -> 0.3860 end to end; 4 s was 0.0019 deg lower in sum, within the tie).
The fourteenth stage (``choose_noise_tau(..., stage=14)``; rule written 2026-12-04 before any candidate ran) asks
whether the road prior of the blend's scheduled cut-off, the root-mean-square rate at which the bank changes, is
a rate in time or along the road: the bank rate at ``vx`` is ``bank_rate (vx / BANK_SPEED_REF)^p``
(:data:`roadbank.estimators.lowpass.BANK_SPEED_REF` = 10 m/s, a round speed of the KITTI drives, fixed before
measuring, so that ``p`` leaves the prior at that speed), over :data:`BANK_SPEED_EXPS` (``p`` = 0: a rate in
time, as every stage before ran; 1: a gradient along the road, crossed faster at speed). The objective is the
twelfth stage's, ties within :data:`TIE_DEG` going to the earlier candidate; and, the thirteenth stage's lesson, a
candidate other than the first is taken only where the mean of the same drive scores (the drives one by one and
every drive of the long logs) is lower than the first's too; otherwise the first stays. It kept 0, a rate in time:
one by one 0.3847 / 0.3883 / 0.3942 deg and end to end 0.3860 / 0.3912 / 0.3985 for 0 / 0.5 / 1 (means 0.4385 /
0.4444 / 0.4540): a faster prior at speed costs on the training drives.

The fifteenth stage (:func:`choose_described_filter`; rule written 2026-12-04 before any candidate ran) chooses the
filter of a quiet log when the car *is* described (a vehicle file or a shipped car's name: ``roadbank estimate LOG
--vehicle CAR``). The fourth stage chose ``pif-adaptive`` for a car nobody described, whose model is a guess; with the
car's own data a filter that leans more on the model may do better. Candidates: :data:`DESCRIBED_FILTERS`, the
shipped :data:`roadbank.vehicle.QUIET_FILTER` first, then the rest of :data:`QUIET_FILTERS` in order. Objective, as
the seventh stage's: each simulated training drive of each shipped car (:func:`simulated_sets`, every one quiet) built
for its own car (``for_log(..., vehicle=load_vehicle(car), quiet_filter=f)``), bank RMS per drive, the median per
car, then the median over the cars (deg); no real log of a described car is at hand, so the simulated drives alone
decide. The lowest wins; ties within :data:`TIE_DEG` go to the earlier candidate; and, as from the fourteenth stage,
a candidate other than the first wins only where the mean over every drive of every car is lower than the first's
too. Neither ``roadbank tune``'s validation set nor the real drives take part. It kept ``pif-adaptive`` (0.2395 deg,
mean 0.2878) by a clear margin: ``pif-gated`` 0.2550, ``pif-rate`` 0.2730, ``pif-rate-adaptive`` 0.2742,
``pif-modified`` 0.2862, ``kinematic-ff`` 0.4076, ``kinematic-lp`` 0.5433, the steering-angle observers 0.83-0.94. The
adaptive weights are worth as much for a car that is described as for one that is not; one quiet filter for every car.

The sixteenth stage (:func:`choose_loud_gate`; rule written 2026-12-04 before any candidate ran) chooses the gate of
the blend again. The second stage broke its tie on the real drives (70 gates within :data:`TIE_DEG`) on simulated
drives that then ran the blend; since the third stage every simulated training drive is quiet and runs the car's
model, so the gate acts only on loud logs, and no stage has chosen it on a loud simulated drive. Candidates: the
shipped gate first, every other point of :data:`GATE_GRID`, then no gate (``gate_on`` = :data:`NO_GATE`: the
low-pass throughout). Objective, real roads first as the second stage's: the KITTI training median (drives one by
one); among the candidates within :data:`TIE_DEG` of the best, the lowest median over the cars of the per-car
medians on the *loud* simulated training drives (:func:`loud_sets`: :func:`simulated_sets` read at
:data:`LOUD_RATE_HZ` with Student-t vibration on ``ay``, built as for a car not described, so the blend runs);
equal to :data:`EQUAL_DEG`: the earlier. A candidate other than the shipped gate wins only where the mean of the
drive scores it was judged on (the eight training drives and every loud simulated drive) is lower than the shipped
gate's too; otherwise the shipped gate stays. It kept the shipped gate: 73 of the 145 candidates tie on the real
drives (0.3846-0.3866 deg; the shipped 0.3847); on the loud simulated drives no gate has the lowest median (0.5800
against the shipped 0.5975) but not the lowest mean (0.8324 against 0.7867 over every score judged; loud simulated
p95 2.49 against 2.05, worst drive 3.15 against 2.44): without the handover the hard transients of a loud log go
wrong, and the mean guard keeps the gate that catches them.

The seventeenth stage (:func:`choose_gate_filter`; rule written 2026-12-04 before any candidate ran) chooses the
time constant of the gate's yaw-rate low-pass (``gate_tf``), which no stage has chosen: it is ``pif-gated``'s
0.05 s, designed on 100 Hz drives with the data sheet's gyro. The gate reads the change of the filtered yaw rate
over one sample; at 10 Hz a 0.05 s filter barely acts (the sample interval is the filter), while at 100 Hz the
noise of that jerk from a given gyro is about ``(0.1 / 0.05)^1.5``, near 2.8 times the 10 Hz one: the gate was
chosen at a rate where its filter does not matter and runs unchanged at one where it does. Candidates
:data:`GATE_TFS` (s), the shipped 0.05 first. Objective, real roads first as the sixteenth stage's and with its
code (:func:`choose_loud_gate`): the KITTI training median; among the candidates within :data:`TIE_DEG` of the best,
the lowest median over the sets of the per-set medians on the loud simulated training drives read at each rate of
:data:`GATE_TF_RATES` (:func:`gate_filter_sets`: the sixteenth stage's 10 Hz set, and the same drives at their own
100 Hz with the same vibration on ``ay``; the gyro is the data sheet's, because no training log says how a shaking
road moves a gyro: eight sets, four cars at two rates); equal to :data:`EQUAL_DEG`: the earlier; the mean guard over
every score judged (the eight training drives and every loud simulated drive at both rates). Neither the KITTI
validation drives nor comma2k19 (the one loud 100 Hz log at hand) take part. It kept 0.05 s: every candidate ties on
the real drives (0.3846-0.3847 deg), and on the loud simulated drives the shipped filter is the lowest by the median
(0.529 deg against 0.558, 0.569, 0.581 for 0.1, 0.2, 0.4 s) and the mean (0.655 against 0.677-0.718); at 100 Hz the
slower filters open the gate later on the transients (median 0.381 against 0.422-0.455, p95 1.02 against 1.18-1.55).

The eighteenth stage (:func:`choose_quiet_floor_rate`; rule written 2026-12-04 before any candidate ran) chooses the
rate at which the quiet decision reads a log's ``ay`` noise floor
(:data:`roadbank.vehicle.conditions.QUIET_FLOOR_RATE`).
A sweep of odd but valid logs found that a KITTI drive written at 100 Hz, as a logger that interpolates its 10 Hz
INS onto a common 100 Hz grid writes it, is called quiet (the floor is read above 3 Hz at 100 Hz, where the
interpolated log carries almost nothing, while the road's noise sits in 1-5 Hz) and gets the car's model, which is
worse there than the raw kinematic estimate. Read at 10 Hz (block means of the samples; white noise reads the same
density either way), the floor would see 1-5 Hz at every rate. Candidates :data:`QUIET_FLOOR_RATES`: 0 (the log's own
rate, shipped) first, 10 Hz. Objective, real roads first: the median over the KITTI training drives at their own
10 Hz and the same drives interpolated linearly onto a 100 Hz grid (:func:`upsampled_logs`; reference roll and scored
samples likewise), sixteen scores; among the candidates within :data:`TIE_DEG` of the best, the lowest median over the
cars of the simulated training drives (100 Hz, data-sheet sensors, car not described); equal to :data:`EQUAL_DEG`: the
earlier; and the mean guard over every score judged (the sixteen real ones and the 96 simulated ones). Neither the
KITTI validation drives nor comma2k19 take part. It kept the log's own rate, by the mean guard. Interpolated onto
100 Hz, three of the eight training drives are quiet at the shipped rate and none at 10 Hz, and the real median falls
from 0.597 to 0.501 deg (the interpolated drives' from 0.820 to 0.558; at 10 Hz nothing changes). But read at 10 Hz,
55 of the 96 simulated drives, whose data-sheet sensors are quiet, read loud: their manoeuvres fill the same 1-5 Hz
that the road's aliased vibration fills on the interpolated drives, and the blend replaces the car's model there
(simulated median 0.257 -> 0.299 deg, mean 0.346 -> 0.394); the mean of every score judged rises 0.385 -> 0.412.

The nineteenth stage (:func:`choose_quiet_floor_signal`; rule written 2026-12-04 before any candidate ran) tries the
candidate the eighteenth named: the floor of the kinematic acceleration ``ay - vx r`` instead of ``ay``
(:data:`roadbank.vehicle.conditions.QUIET_FLOOR_SIGNAL`). A manoeuvre moves ``ay`` mostly through its centripetal
part ``vx r``, which the gyro measures almost without noise; what is left is the sideslip acceleration, the bank and
the noise, so a simulated drive's manoeuvres should fill the 1-5 Hz band much less, while the road's vibration on an
interpolated KITTI drive stays. Candidates :data:`QUIET_FLOOR_READINGS` (channel, rate Hz): ``ay`` at the log's own
rate (shipped) first, ``ay - vx r`` at the log's own rate, ``ay - vx r`` read at 10 Hz. The rule, the sets and the
code are the eighteenth stage's (:func:`_roads_then_guarded`): the median over the KITTI training drives at 10 Hz and
interpolated onto 100 Hz (sixteen scores); among the candidates within :data:`TIE_DEG` of the best, the lowest median
over the cars of the simulated training drives (100 Hz, data-sheet sensors, car not described); equal to
:data:`EQUAL_DEG`: the earlier; the mean guard over every score judged. Neither the KITTI validation drives nor
comma2k19 take part.

The twentieth stage (:func:`choose_noise_at_source`; rule written 2026-12-04 before any candidate ran) reads the
cause the eighteenth and nineteenth found: on a KITTI drive interpolated onto 100 Hz the channels are straight lines
between the INS's 10 Hz samples, and the noise a design reads above the dynamics band is not there. Such a channel is
recognised from its second differences, which vanish between the source's samples
(:func:`roadbank.signals.source_step`; 10 on every interpolated training drive, 1 on every KITTI drive at its own
rate, every simulated drive and comma2k19), and read on the source's samples
(:data:`roadbank.vehicle.conditions.NOISE_AT_SOURCE`). Candidates :data:`NOISE_AT_SOURCE_CHOICES`: ``"none"``
(shipped) first, ``"floor"`` (only the ``ay`` floor that the quiet decision reads), ``"all"`` (every noise reading of
``ay`` and the yaw rate, so the design's densities too). The rule, the sets and the code are the eighteenth stage's
(:func:`_roads_then_guarded`), as in the nineteenth. Neither the KITTI validation drives nor comma2k19 take part.

The nineteenth stage kept ``ay`` at the log's own rate, by the mean guard: ``ay - vx r`` at the log's rate decides as
``ay`` does (real median 0.597 deg); read at 10 Hz it calls no interpolated drive quiet (0.501) but still calls the
simulated drives loud (median 0.257 -> 0.299, mean 0.346 -> 0.407; every score judged 0.385 -> 0.423): the sideslip
acceleration and the body's roll, not the centripetal part, fill their 1-5 Hz. The twentieth chose ``"all"``: real
median 0.597 (none) / 0.501 (floor) / 0.397 (all; the interpolated drives 0.820 / 0.558 / 0.401 against 0.385 at
their own 10 Hz), the simulated drives unchanged (none is read otherwise: median 0.257, mean 0.346), every score
judged 0.385 -> 0.360. The eighteenth and nineteenth stages run as they ran, every channel at the log's rate.

The twenty-first stage (:func:`choose_noise_octave`; rule written 2026-12-04 before any candidate ran) takes the
same failure from the other side: a logger that resamples without aliasing (a polyphase low-pass, as
``scipy.signal.resample_poly`` or an anti-aliased logger writes a 10 Hz INS at 100 Hz), or a sensor's own low-pass,
leaves no straight lines to recognise, just nothing above the source's Nyquist frequency, and the noise read above
3 Hz at 100 Hz, taken as white up to 50 Hz, is then a small part of what the road puts where the low-pass's stop
band begins (measured on the training drives so resampled: every one is called quiet, median 0.84 deg against 0.385
at their own 10 Hz). Candidates :data:`NOISE_OCTAVES` (:data:`roadbank.vehicle.conditions.NOISE_OCTAVE`): ``"none"``
(shipped: white over the whole band above the dynamics band), ``"fast"`` (the density of the octave above the
dynamics band, ``band .. 2 band``, taken as the whole band's, on logs whose band is the dynamics band, 30 Hz or
faster; a 10 Hz log as before), ``"all"`` (that octave at every rate: 1-2 Hz at 10 Hz). White noise reads the same
either way. The rule, the guard and the code are the eighteenth stage's (:func:`_roads_then_guarded`), the real
part over twenty-four scores: the eight KITTI training drives at 10 Hz, interpolated linearly onto 100 Hz
(:func:`upsampled_logs`) and resampled onto 100 Hz (:func:`resampled_logs`); the simulated training drives as
before. Neither the KITTI validation drives nor comma2k19 take part.

It chose ``"all"``. Real median over the twenty-four scores 0.5735 (none) / 0.4168 (fast) / 0.4144 (all): the resampled
drives 0.844 / 0.439 / 0.439, the interpolated ones 0.4006 / 0.4006 / 0.3968, the 10 Hz ones 0.3847 / 0.3847 / 0.3856
(five of the eight a little worse, by up to 0.019 deg, two better). ``"all"`` leads ``"fast"`` by 0.0024 deg, just
more than the tie, so it is chosen on the real median; the simulated drives (read in 3-6 Hz under either) move from
0.2569 to 0.2551 (median; mean 0.3460 -> 0.3470), and the mean of every score judged falls 0.3983 -> 0.3698.

The twenty-second stage (:func:`choose_octave_top`; rule written 2026-12-04 before any candidate ran) chooses the width
of that band, which the twenty-first fixed at one octave: a wider band reads more degrees of freedom (a 3 Hz band over
15 s spreads about 10 % in standard deviation) but reaches further from where the low-pass's stop band begins, a
narrower one the reverse. Candidates :data:`NOISE_OCTAVE_TOPS` (the top as a multiple of the lower edge; 2 shipped
first; at 10 Hz the top is at most the Nyquist frequency, so 4 and more read the whole band there). The rule, the sets
and the code are the twenty-first stage's. Neither the KITTI validation drives nor comma2k19 take part.

It chose 1.5. Real median 0.4144 (2) / **0.4083** (1.5) / 0.4263 (3) / 0.4319 (4): the resampled drives 0.4389 /
0.4187 / 0.4682 / 0.4958 (their polyphase filter already rolls off at 4-5 Hz of the 10 Hz source), the interpolated
ones 0.3968 / 0.3967 / 0.3970 / 0.3974, the 10 Hz ones 0.3856 / 0.3861 / 0.3877 / 0.3864. The simulated drives 0.2551
-> 0.2553 (median; mean 0.3470 -> 0.3459); every score judged 0.3698 -> 0.3677. The price is the spread of the
narrower band (a 1.5 Hz band over 15 s at 100 Hz: about 11 % in standard deviation); every simulated training drive
stays quiet.

The twenty-third stage (:func:`choose_prior_again`; rule written 2026-12-05 before any candidate ran) chooses the
first stage's pair again, the blend's bank-rate prior and ``kappa``, with every later choice in place. The first
stage ran with no lead, the static car, a linear low-pass, no running noise, and the noise read over the whole band
at the log's rate; run as it ran but with today's noise reading, it takes its tied neighbour (0.7 deg/s, kappa
0.25). Candidates: the shipped pair first, then every other pair of :data:`BANK_RATES_DEG` x :data:`KAPPAS` in the
grid's order, ``kinematic-pif`` built as the command line builds it. The rule and the code are the eighteenth
stage's (:func:`_roads_then_guarded`). The real sets are the twenty-second stage's: the KITTI training drives at
10 Hz, interpolated and resampled to 100 Hz. The simulated sets are the sixteenth stage's loud drives
(:func:`loud_sets`). The pair acts only there: every simulated training drive at its own rate is quiet and runs the
car's model. Neither the KITTI validation drives nor comma2k19 take part.

It kept the shipped pair (0.6 deg/s, 0.2), by the mean guard. The real median's best is 0.5 deg/s, kappa 0.25:
0.4020 against 0.4083, beyond the tie, alone within it. Its gain is on the resampled drives (0.4187 -> 0.4030); the
10 Hz drives lose (0.3861 -> 0.3953), the interpolated ones lose too (0.3967 -> 0.4020). On the loud simulated
drives it is worse (median 0.6164 -> 0.6854), and so is the mean of every score judged (0.7653 -> 0.8022).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import resample_poly

from ... import vehicle
from ...vehicle import conditions
from ...estimators.gated import KINEMATIC_PIF_BANK_RATE, KINEMATIC_PIF_GATE, KINEMATIC_PIF_KAPPA
from ...estimators.kinematic_smoother import KinematicSmoother
from ...estimators.lowpass import KinematicLowPass
from ...estimators.offsets import with_online_offsets
from ...sim import SCENARIOS, run_scenario
from ...params import ESP_R_NOISE, ESP_R_RESOLUTION
from ...sim.params import PlantParams
from ...sim.sensors import ChannelErrorModel, SensorConfig
from ..manoeuvres import drive_set
from ...signals import Signals, concat_signals, sample_rate
from ...validation.kitti import KITTI_SCORING
from ...validation.scoring import masks
from ...vehicle import load_vehicle
from .common import (BEFORE_64, BEFORE_69, EQUAL_DEG, SIM_CARS, SIM_DRIVES, TIE_DEG, cars_median, fixed, guarded,
                     log_errors, lowest_tied, objective, per_log, rms_deg, sim_errors, within)


#: candidate cut-offs (Hz) and feed-forward gains (-)
CUTOFFS_HZ = (0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.8)
KAPPAS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4)
#: gate candidates of ``kinematic-pif``: ``gate_on`` (m/s^3), ``gate_span`` (m/s^3), ``gate_release`` (s)
GATE_GRID = {"gate_on": (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0), "gate_span": (1.0, 2.0, 4.0, 8.0),
             "gate_release": (1.0, 2.0, 4.0, 8.0)}
#: candidate root-mean-square bank rates of roads (deg/s) for ``kinematic-pif``'s scheduled low-pass
BANK_RATES_DEG = (0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 1.0)
#: candidate quiet ratios of ``kinematic-pif`` (-; 0: never quiet)
QUIET_RATIOS = (0.0, 1.5, 2.0, 3.0, 6.0, 10.0, 30.0, 100.0)
#: candidate lowest speeds (m/s) of ``kinematic-pif``'s blend, highest first
V_MINS = (5.0, 4.0, 3.0, 2.0, 1.0)
#: candidate sampled-data leads of ``kinematic-pif``'s low-pass (sample intervals of the log; 0: the
#: continuous-time filter, 0.5: the lag of the first-order filter of the samples)
LEADS_SAMPLES = (0.0, 0.25, 0.5, 0.75, 1.0)
#: candidate filters of ``kinematic-pif`` on a quiet log: the causal estimators that read the
#: car's model, the stage-3 choice (the default PIF) first, and the two low-passes
QUIET_FILTERS = ("pif-modified", "pif-rate", "pif-gated", "pif-adaptive", "pif-rate-adaptive", "pio-modified",
                 "kalman", "dfc", "kinematic-ff", "kinematic-lp")
#: candidate margins (-) by which another shipped car must fit a log better to replace the static one
#: (:func:`roadbank.vehicle.design_car`); ``inf``: the static car (as before the eighth stage), first
CAR_MARGINS = (math.inf, 1.0, 1.1, 1.25, 1.5, 2.0, 3.0)
#: how a log's ``ay`` is read for the quiet decision (:func:`roadbank.vehicle.is_quiet`), the ninth stage's
#: candidates: ``"mean"`` its road noise over the design span (as the stages before the ninth ran),
#: ``"floor"`` its noise floor (:func:`roadbank.signals.road_noise_floor_std`)
QUIET_MEASURES = ("mean", "floor")
#: the ninth stage's tie-break: the paper's scenarios (:data:`roadbank.sim.SCENARIOS`) of every car of
#: :data:`SIM_CARS` at these noise seeds, nominal conditions
PAPER_SEEDS = (0, 1, 2)
#: candidate limits of ``kinematic-pif``'s low-pass update (-, standard deviations of its input's white noise;
#: :func:`roadbank.estimators.kernels.sample.limited_ay`), the tenth stage's; 0: linear (the stages before), first
CLIPS = (0.0, 6.0, 4.0, 3.0, 2.5, 2.0, 1.5)
#: candidate time constants (s) of the running noise estimate that ``kinematic-pif``'s limited low-pass follows
#: (:func:`roadbank.estimators.kernels.sample.noise_update`), the twelfth stage's; 0: the design span's noise
#: throughout (the stages before), first; then the longer first (ties go to the earlier)
NOISE_TAUS = (0.0, 60.0, 30.0, 15.0, 8.0, 4.0)
#: seconds between the training drives put end to end (:func:`long_logs`): more than a restart's gap
LONG_GAP_S = 2.0
#: candidate time constants (s) of the shorter running noise ratio that the limit alone reads, the thirteenth
#: stage's; 0: the gain's ratio (the stages before), first; then the longer first (ties go to the earlier)
LIMIT_TAUS = (0.0, 8.0, 4.0, 2.0, 1.0)
#: the fourteenth stage's exponents (-) of the speed in the bank-rate prior: a rate in time first
BANK_SPEED_EXPS = (0.0, 0.5, 1.0)
#: the fifteenth stage's candidate filters of a quiet log whose car is described: the shipped one first
DESCRIBED_FILTERS = (vehicle.QUIET_FILTER, *(f for f in QUIET_FILTERS if f != vehicle.QUIET_FILTER))
#: the sixteenth stage's loud simulated drives: read at this rate (Hz, KITTI's), with Student-t vibration of this many
#: degrees of freedom and this RMS (m/s^2, KITTI's training drives carry 0.07-0.33) added to ``ay``, numpy seed
LOUD_RATE_HZ, LOUD_DOF, LOUD_AY_NOISE, LOUD_SEED = 10.0, 4, 0.15, 1
#: ``gate_on`` (m/s^3) of the sixteenth stage's candidate without a gate: no yaw jerk of a car reaches it
NO_GATE = 1e9
#: the seventeenth stage's candidate time constants (s) of the gate's yaw-rate low-pass ``gate_tf``, the shipped first
GATE_TFS = (KINEMATIC_PIF_GATE["gate_tf"], 0.1, 0.2, 0.4)
#: the rates (Hz) at which the seventeenth stage reads the loud simulated drives: the sixteenth's, and their own
GATE_TF_RATES = (LOUD_RATE_HZ, 100.0)
#: the eighteenth stage's candidate rates (Hz) at which the quiet decision reads the ``ay`` floor (0: the log's own)
QUIET_FLOOR_RATES = (0.0, 10.0)
#: the nineteenth stage's candidates: (the channel the quiet decision reads the floor of, the rate Hz it reads it at)
QUIET_FLOOR_READINGS = (("ay", 0.0), ("ay - vx r", 0.0), ("ay - vx r", 10.0))
#: the twentieth stage's candidates: which noise readings take a channel at its source's rate (the shipped first)
NOISE_AT_SOURCE_CHOICES = conditions.NOISE_AT_SOURCE_CHOICES
#: the twenty-first stage's candidates: where the noise is read in one octave above the dynamics band (the shipped
#: first)
NOISE_OCTAVES = conditions.NOISE_OCTAVES
#: the twenty-second stage's candidate tops of the band the noise is read in, as multiples of its lower edge (the
#: shipped first)
NOISE_OCTAVE_TOPS = (2.0, 1.5, 3.0, 4.0)
#: how many times faster than its source the twenty-first stage's resampled KITTI training drives are written
RESAMPLE_FACTOR = 10
#: the rate (Hz) of the eighteenth stage's interpolated KITTI training drives
UPSAMPLED_RATE_HZ = 100.0
#: the rates (Hz) at which the fifty-third stage writes each KITTI training drive holding every frame
HELD_RATES_HZ = (50.0, 100.0)
#: the fifty-third stage's rule: B ships if its median is below A's by more than this (deg) ...
GATE_SOURCE_GAIN_DEG = 0.005
#: ... and it is worse than A by more than this (deg) on at most :data:`GATE_SOURCE_WORSE_LOGS` logs
GATE_SOURCE_WORSE_DEG = 0.02
GATE_SOURCE_WORSE_LOGS = 4
#: the fifty-fifth stage's rule (docs/estimators.md): B ships if its median over the ESP forms is below A's by more
#: than this (deg), its median over the gyro-aided forms not above A's by more than it ...
READ_SOURCE_GAIN_DEG = 0.005
#: ... and it is worse than A by more than this (deg) on at most :data:`READ_SOURCE_WORSE_LOGS` of all the logs
READ_SOURCE_WORSE_DEG = 0.02
READ_SOURCE_WORSE_LOGS = 4
#: the fifty-sixth stage's rule (docs/estimators.md): B ships unless its objective is above A's by more than this (deg)
QUIET_GYRO_LOSS_DEG = 0.005
#: the roll-rate offsets (rad/s) of its simulated sets (:func:`gyro_sim_sets`)
QUIET_GYRO_OFFSETS = (0.0, math.radians(0.3))
#: the fifty-seventh stage's rule (docs/estimators.md): B ships if its median over the ESP forms is below A's by more
#: than this (deg), its median over the gyro-aided forms not above A's by more than it ...
SOURCE_ROUNDING_GAIN_DEG = 0.005
#: ... and it is worse than A by more than this (deg) on at most :data:`SOURCE_ROUNDING_WORSE_LOGS` of all the logs
SOURCE_ROUNDING_WORSE_DEG = 0.02
SOURCE_ROUNDING_WORSE_LOGS = 4
#: its two roundings (grid step per channel, SI units: m/s, m/s^2, rad/s): a CSV in SI units with three decimals, and
#: ``ay`` to 0.001 m/s^2 with the rates to 0.01 deg/s and the speed to 0.01 m/s
ROUNDINGS = ({"vx": 1e-3, "ay": 1e-3, "ax": 1e-3, "r": 1e-3, "p": 1e-3, "q": 1e-3},
             {"vx": 1e-2, "ay": 1e-3, "ax": 1e-3, "r": math.radians(0.01), "p": math.radians(0.01),
              "q": math.radians(0.01)})
#: the noise scales (-, of the data sheet's) of its simulated guard drives
SOURCE_ROUNDING_SIM_NOISE = (1.0, 0.5)
#: the stages before the fourteenth took the bank-rate prior as a rate in time
_TIME_RATE = {"bank_speed_exp": 0.0}
#: the stages before the twelfth ran on the design span's noise throughout
_DESIGN_NOISE = {"noise_tau": 0.0, **_TIME_RATE}
#: the stages before the thirteenth: the limit reads the gain's ratio
_ONE_RATIO = {"limit_tau": 0.0, **_TIME_RATE}
#: the stages before the tenth ran with the linear low-pass (no limit: no running noise either)
_LINEAR = {"clip": 0.0, **_TIME_RATE}
#: the stages before the eighth designed a car not described for the static car
_STATIC_CAR = {"car_margin": math.inf, **_LINEAR}
#: the stages before the sixth ran without the sampled-data lead
_NO_LEAD = {"lead_samples": 0.0, **_STATIC_CAR}


@dataclass(frozen=True)
class LowpassChoice:
    """Result of :func:`choose_lowpass`: the chosen ``(cutoff Hz, kappa)`` pairs and every objective (deg)."""

    lp: tuple[float, float]
    ff: tuple[float, float]
    objective: dict


def _pick(cands: dict) -> tuple[float, float]:
    return lowest_tied(cands, lambda fk: (fk[1], fk[0]))


def choose_lowpass(logs, sim_sets, cutoffs=CUTOFFS_HZ, kappas=KAPPAS, estimator=KinematicLowPass) -> LowpassChoice:
    """Apply the module's rule to ``logs`` (from :func:`training_logs`) and ``sim_sets``
    (from :func:`simulated_sets`), for the low-pass class ``estimator`` (default ``kinematic-lp``'s).

    Returns the chosen ``(cutoff Hz, kappa)`` of ``kinematic-lp`` (kappa 0) and of ``kinematic-ff``.
    """
    if not logs:
        raise ValueError("choose_lowpass: no training drives")
    obj = {(fc, k): objective(fixed(estimator(cutoff=fc, kappa=k)), logs, sim_sets)
           for fc in cutoffs for k in kappas}
    lp = _pick({fk: v for fk, v in obj.items() if fk[1] == 0.0})
    return LowpassChoice(lp=lp, ff=_pick(obj), objective=obj)


def choose_smoother(logs, sim_sets, cutoffs=CUTOFFS_HZ) -> tuple[float, dict]:
    """The cut-off (Hz) of ``kinematic-smoother`` by the rule of ``kinematic-lp`` (module docstring: the sum
    of the real and the simulated medians over :data:`CUTOFFS_HZ`; ties within :data:`TIE_DEG` to the
    smaller cut-off), and every objective (deg)."""
    choice = choose_lowpass(logs, sim_sets, cutoffs, kappas=(0.0,), estimator=KinematicSmoother)
    return choice.lp[0], {fc: v for (fc, _), v in choice.objective.items()}


def choose_described_ratio(sim_sets, cars=SIM_CARS, ratios=QUIET_RATIOS) -> tuple[float, dict]:
    """The seventh stage: the quiet ratio of ``kinematic-pif`` for a car that is described. Each candidate
    ratio (:data:`QUIET_RATIOS`) builds the default for each simulated training drive of each car in
    ``cars`` with that car's own file (``for_log(..., vehicle=load_vehicle(car))``, as
    ``roadbank estimate --vehicle CAR`` does, never trimmed to the drive: :data:`~.common.BEFORE_69`, as the stage
    ran); bank RMS per drive, median per car, median over the cars
    (deg). No real log of a described car is at hand, so the simulated drives alone decide; the lowest
    wins, ties within :data:`EQUAL_DEG` to the smaller ratio (fewer logs leave the low-pass). Returns
    ``(ratio, {ratio: median})``."""
    meds: dict[float, float] = {}
    for q in sorted(ratios):
        builds = [within(per_log("kinematic-pif", vehicle=load_vehicle(c), quiet_ratio=q), **BEFORE_69) for c in cars]
        meds[q] = float(np.median([objective(b, [], [drives]) for b, drives in zip(builds, sim_sets)]))
    return min(meds, key=lambda q: (round(meds[q] / EQUAL_DEG), q)), meds


def choose_described_filter(sim_sets, cars=SIM_CARS, filters=DESCRIBED_FILTERS) -> tuple[str, dict]:
    """The fifteenth stage: the filter of a quiet log whose car is described (module docstring). Each candidate of
    ``filters`` (default :data:`DESCRIBED_FILTERS`, the shipped one first) builds the default for each simulated
    training drive of each car in ``cars`` (``sim_sets`` from :func:`simulated_sets`, in that order) with that
    car's own file and ``quiet_filter`` (never trimmed to the drive: :data:`~.common.BEFORE_69`, as the stage ran);
    bank RMS per drive (deg). The lowest median over the cars of the per-car
    medians wins, ties within :data:`TIE_DEG` to the earlier candidate; a candidate other than the first wins only
    where the mean over every drive is lower than the first's too. Returns ``(filter, {filter: (median, mean)})``."""
    scores: dict[str, tuple[float, float]] = {}
    for f in filters:
        errs = [sim_errors(within(per_log("kinematic-pif", vehicle=load_vehicle(car), quiet_filter=f), **BEFORE_69),
                           [drives])[0] for car, drives in zip(cars, sim_sets)]
        scores[f] = (cars_median(errs), float(np.mean(np.concatenate(errs))))
    best = min(m for m, _ in scores.values())
    chosen = next(f for f in filters if scores[f][0] <= best + TIE_DEG)
    return guarded(chosen, filters[0], {f: mean for f, (_, mean) in scores.items()}), scores


def loud_sets(sim_sets, rate: float = LOUD_RATE_HZ, dof: int = LOUD_DOF, noise: float = LOUD_AY_NOISE,
              seed: int = LOUD_SEED) -> list:
    """``sim_sets`` (:func:`simulated_sets`) as a 10 Hz INS on a shaking road reads them: every drive sampled at
    ``rate`` Hz (every n-th sample of its log) and Student-t noise with ``dof`` degrees of freedom and RMS ``noise``
    (m/s^2) added to its ``ay`` (one numpy generator, ``seed``, drawn in the sets' order); the true bank likewise."""
    rng = np.random.default_rng(seed)
    scale = noise / math.sqrt(dof / (dof - 2.0))
    out = []
    for drives in sim_sets:
        loud = []
        for d in drives:
            s = d.signals
            step = max(1, int(round(sample_rate(s.t) / rate)))
            ay = s.ay[::step] + scale * rng.standard_t(dof, len(s.ay[::step]))
            loud.append(dataclasses.replace(d, signals=Signals(s.t[::step], s.vx[::step], ay, s.r[::step],
                                                               s.delta_f[::step]), phi_b=d.phi_b[::step]))
        out.append(loud)
    return out


def loud_gate_candidates() -> dict:
    """``{(gate_on, gate_span, gate_release): build}`` of the sixteenth stage: the shipped gate, the rest of
    :data:`GATE_GRID`, no gate (:data:`NO_GATE`), in that order; ``kinematic-pif`` built as the command line does."""
    g = KINEMATIC_PIF_GATE
    shipped = (g["gate_on"], g["gate_span"], g["gate_release"])
    keys = [shipped] + [k for k in itertools.product(*GATE_GRID.values()) if k != shipped] + [(NO_GATE, 1.0, 1.0)]
    return {k: per_log("kinematic-pif", gate_on=k[0], gate_span=k[1], gate_release=k[2]) for k in keys}


def choose_loud_gate(logs, sim_sets, cands: dict | None = None) -> tuple:
    """The sixteenth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs`) and the loud
    simulated drives ``sim_sets`` (:func:`loud_sets`), over ``cands`` (default :func:`loud_gate_candidates`; the
    first is the shipped gate); the seventeenth's too, over its own candidates (:func:`choose_gate_filter`).
    Returns ``(chosen key, {key: real median}, {key: loud simulated median})``, the
    latter for the shipped gate and the candidates within :data:`TIE_DEG` of the best real median."""
    chosen, real, sim = _roads_then_guarded(loud_gate_candidates() if cands is None else cands, logs, sim_sets)
    return chosen, {k: float(np.median(e)) for k, e in real.items()}, {k: cars_median(v) for k, v in sim.items()}


def _roads_then_guarded(cands: dict, logs, sim_sets) -> tuple:
    """The sixteenth to eighteenth stages' rule over ``cands`` (``{key: build}``, the shipped first): the median over
    ``logs`` (:func:`log_errors`); among the candidates within :data:`TIE_DEG` of the best, the lowest
    :func:`cars_median` over ``sim_sets`` (equal to :data:`EQUAL_DEG`: the earlier); then :func:`guarded` by the mean
    of every score judged. Returns ``(chosen key, {key: real scores}, {key: simulated scores})`` (deg), the
    simulated ones for the shipped candidate and the tied ones."""
    real = {k: log_errors(b, logs) for k, b in cands.items()}
    best = min(float(np.median(e)) for e in real.values())
    tied = [k for k in cands if float(np.median(real[k])) <= best + TIE_DEG]
    first = next(iter(cands))
    sim = {k: sim_errors(cands[k], sim_sets) for k in dict.fromkeys([first, *tied])}
    chosen = min(tied, key=lambda k: round(cars_median(sim[k]) / EQUAL_DEG))
    mean = {k: float(np.mean(np.concatenate([real[k], *v]))) for k, v in sim.items()}
    return guarded(chosen, first, mean), real, sim


def gate_filter_sets(sim_sets, rates=GATE_TF_RATES) -> list:
    """The seventeenth stage's loud simulated drives: :func:`loud_sets` of ``sim_sets`` at each rate (Hz) of
    ``rates``, one set per (rate, car), each drawn from the same seed (the first rate's sets are the sixteenth's)."""
    return [drives for rate in rates for drives in loud_sets(sim_sets, rate=rate)]


def choose_gate_filter(logs, sim_sets, tfs=GATE_TFS) -> tuple:
    """The seventeenth stage (module docstring): :func:`choose_loud_gate` over ``kinematic-pif`` built as the command
    line does with each ``gate_tf`` (s) of ``tfs`` (the shipped first), on the KITTI training ``logs`` and the loud
    simulated drives ``sim_sets`` (:func:`gate_filter_sets`). Returns what :func:`choose_loud_gate` returns, keyed by
    ``gate_tf``."""
    return choose_loud_gate(logs, sim_sets, {tf: per_log("kinematic-pif", gate_tf=tf) for tf in tfs})


def _grid(t: np.ndarray, rate: float) -> np.ndarray:
    """A uniform time base (s) at ``rate`` (Hz) from the first of the stamps ``t`` (s) to at most their last."""
    return t[0] + np.arange(int(np.floor((t[-1] - t[0]) * rate)) + 1) / rate


def upsampled_logs(logs, rate: float = UPSAMPLED_RATE_HZ, scoring=KITTI_SCORING) -> list:
    """``logs`` (:func:`training_logs`) as a logger that interpolates its channels onto a common ``rate`` (Hz) grid
    writes them: every channel and the reference roll (rad) linear in time between the samples, the grid from the
    first sample on; the scored samples recomputed on the grid with ``scoring``."""
    out = []
    for s, ref, _ in logs:
        t = _grid(s.t, rate)
        up = Signals(t, *(np.interp(t, s.t, getattr(s, c)) for c in ("vx", "ay", "r", "delta_f")))
        out.append((up, np.interp(t, s.t, ref), masks(up.t, up.vx, scoring)[1]))
    return out


#: the settings as each stage ran: the eighteenth and nineteenth before the twentieth, the twentieth before the
#: twenty-first
_BEFORE_SOURCE = {"noise_at_source": "none", "noise_octave": "none"}
_BEFORE_OCTAVE = {"noise_octave": "none"}


def choose_octave_top(logs, up, resampled, sim_sets, tops=NOISE_OCTAVE_TOPS) -> tuple:
    """The twenty-second stage (module docstring): :func:`choose_noise_octave`'s rule and sets over ``tops``
    (:data:`roadbank.vehicle.conditions.NOISE_OCTAVE_TOP` values, the shipped first). Returns ``(chosen, {top: real
    scores}, {top: simulated scores})``, the simulated ones for the shipped top and the candidates within
    :data:`TIE_DEG` of the best real median."""
    return _roads_then_guarded({w: _with_settings(noise_octave_top=w) for w in tops}, logs + up + resampled, sim_sets)


def _with_settings(**settings):
    """``build`` of the default as the command line builds it, within :func:`design_settings` ``(**settings)``: the
    design, where the settings are read, is built inside the block."""
    return within(per_log("kinematic-pif"), **settings)


def choose_quiet_floor_rate(logs, up, sim_sets, rates=QUIET_FLOOR_RATES) -> tuple:
    """The eighteenth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs`), the same
    interpolated (``up``, :func:`upsampled_logs`) and the simulated training drives ``sim_sets``
    (:func:`simulated_sets`), over ``rates`` (Hz; the shipped first). Returns ``(chosen rate, {rate: real scores},
    {rate: simulated scores})``, the simulated ones for the shipped rate and the candidates within :data:`TIE_DEG`
    of the best real median."""
    return _roads_then_guarded({rate: _with_settings(quiet_floor_rate=rate, **_BEFORE_SOURCE) for rate in rates},
                               logs + up, sim_sets)


def choose_quiet_floor_signal(logs, up, sim_sets, readings=QUIET_FLOOR_READINGS) -> tuple:
    """The nineteenth stage (module docstring): :func:`choose_quiet_floor_rate`'s rule and sets over ``readings``
    (``(channel, rate Hz)`` pairs, the shipped first). Returns ``(chosen reading, {reading: real scores},
    {reading: simulated scores})``, the simulated ones for the shipped reading and the candidates within
    :data:`TIE_DEG` of the best real median."""
    return _roads_then_guarded({(sig, rate): _with_settings(quiet_floor_rate=rate, quiet_floor_signal=sig,
                                                            **_BEFORE_SOURCE) for sig, rate in readings},
                               logs + up, sim_sets)


def choose_noise_at_source(logs, up, sim_sets, choices=NOISE_AT_SOURCE_CHOICES) -> tuple:
    """The twentieth stage (module docstring): :func:`choose_quiet_floor_rate`'s rule and sets over ``choices``
    (:data:`roadbank.vehicle.conditions.NOISE_AT_SOURCE` values, the shipped first). Returns ``(chosen, {choice: real
    scores}, {choice: simulated scores})``, the simulated ones for the shipped choice and the candidates within
    :data:`TIE_DEG` of the best real median."""
    return _roads_then_guarded({c: _with_settings(noise_at_source=c, **_BEFORE_OCTAVE) for c in choices},
                               logs + up, sim_sets)


def resampled_logs(logs, factor: int = RESAMPLE_FACTOR, scoring=KITTI_SCORING) -> list:
    """``logs`` (:func:`training_logs`) as a logger that resamples its channels without aliasing writes them: each
    drive first linear onto a uniform grid at its own median rate, then ``factor`` times faster by a polyphase
    low-pass (``scipy.signal.resample_poly``; nothing above the source's Nyquist frequency); the reference roll (rad)
    linear onto the same grid; the scored samples recomputed with ``scoring``."""
    out = []
    for s, ref, _ in logs:
        rate = sample_rate(s.t)
        base = _grid(s.t, rate)
        t = s.t[0] + np.arange(base.size * factor) / (rate * factor)
        up = Signals(t, *(resample_poly(np.interp(base, s.t, getattr(s, c)), factor, 1)
                          for c in ("vx", "ay", "r", "delta_f")))
        out.append((up, np.interp(t, s.t, ref), masks(up.t, up.vx, scoring)[1]))
    return out


def held_logs(logs, rate: float, scoring=KITTI_SCORING) -> list:
    """``logs`` (:func:`training_logs`) as a logger that writes its channels onto a ``rate`` (Hz) grid by holding each
    frame writes them: every channel (the roll rate, ``ax`` and pitch rate too where the log has them) the last
    frame's value at or before each grid time, the grid from the first frame on; the reference roll (rad) linear in
    time (the truth at the grid time); the scored samples recomputed with ``scoring``."""
    out = []
    for s, ref, _ in logs:
        t = _grid(s.t, rate)
        last = np.searchsorted(s.t, t, side="right") - 1
        up = Signals(**{c: t if c == "t" else getattr(s, c)[last] for c in s.channels}, fixed=s.fixed,
                     unbiased=s.unbiased)
        out.append((up, np.interp(t, s.t, ref), masks(up.t, up.vx, scoring)[1]))
    return out


def choose_gate_at_source(logs, forms) -> tuple:
    """The fifty-third stage (docs/estimators.md): ``kinematic-pif`` as ``roadbank estimate`` runs it (designed for
    each log, behind the online offset learner) with :data:`roadbank.vehicle.conditions.GATE_AT_SOURCE` False (A, as
    shipped before) and True (B), on ``forms`` (the KITTI training drives written held and interpolated: a list of
    logs). Returns ``(chosen, {choice: raw RMS per log (deg)})``. ``logs`` (the drives as recorded) must give the same
    outputs under both (their yaw rate is at its sensor's rate): a ValueError where they do not."""
    def build(choice):                  # as the stage ran: before the fifty-fifth read held logs at their source
        at = _with_settings(gate_at_source=choice, read_at_source=False)
        return lambda s: with_online_offsets(at(s))

    for s, _, _ in logs:
        a, b = (build(c)(s).run(s).theta for c in (False, True))
        if not np.array_equal(a, b):
            raise ValueError("a log at its sensors' rate got another design: the stage's guard fails")
    errs = {c: log_errors(build(c), forms) for c in (False, True)}
    a, b = np.array(errs[False]), np.array(errs[True])
    ships = (np.median(b) < np.median(a) - GATE_SOURCE_GAIN_DEG
             and int(np.sum(b > a + GATE_SOURCE_WORSE_DEG)) <= GATE_SOURCE_WORSE_LOGS)
    return bool(ships), errs


def choose_read_at_source(esp_logs, gyro_logs, esp_forms, gyro_forms) -> tuple:
    """The fifty-fifth stage (docs/estimators.md): ``kinematic-pif`` as ``roadbank estimate`` runs it (designed for
    each log, behind the online offset learner) with :data:`roadbank.vehicle.conditions.READ_AT_SOURCE` False (A, as
    shipped before) and True (B), on the KITTI training drives written held (:func:`held_logs`) with their ESP
    channels alone (``esp_forms``) and with their roll rate, ``ax`` and pitch rate (``gyro_forms``). Returns
    ``(chosen, {choice: (raw RMS per ESP form, per gyro form) (deg)})``. The drives as recorded (``esp_logs``,
    ``gyro_logs``) must give the same outputs under both (none repeats its rows): a ValueError where they do not."""
    def build(choice):
        at = _with_settings(read_at_source=choice)
        return lambda s: with_online_offsets(at(s))

    same_outputs(build, [s for s, _, _ in esp_logs + gyro_logs], (False, True),
                 "a log at its sensors' rate was read otherwise: the stage's guard fails")
    return esp_and_gyro_rule(build, esp_forms, gyro_forms, READ_SOURCE_GAIN_DEG, READ_SOURCE_WORSE_DEG,
                             READ_SOURCE_WORSE_LOGS)


def same_outputs(build, signals, choices, why: str) -> None:
    """A stage's guard: ``build(choice)(s)`` gives the same ``theta`` for every choice of ``choices`` on each log of
    ``signals``; a ValueError saying ``why`` where it does not."""
    for s in signals:
        first, *others = (build(c)(s).run(s).theta for c in choices)
        if not all(np.array_equal(first, o, equal_nan=True) for o in others):
            raise ValueError(why)


def two_choice_rule(build, kept, choices, why: str, logs, gain: float) -> tuple:
    """A stage's rule between ``build(a)`` (A, shipped) and ``build(b)`` (B), ``choices = (a, b)``: the guard
    :func:`same_outputs` on the signals ``kept`` (``why``), then the raw RMS per log of ``logs``
    (:func:`~roadbank.tuning.real.log_errors`); B if its median is below A's by more than ``gain`` (deg), else A.
    Returns ``(chosen, {choice: raw RMS per log (deg)})``."""
    a, b = choices
    same_outputs(build, kept, choices, why)
    errs = {c: log_errors(build(c), logs) for c in choices}
    return (b if np.median(errs[b]) < np.median(errs[a]) - gain else a), errs


def esp_and_gyro_rule(build, esp_forms, gyro_forms, gain: float, worse_deg: float, worse_logs: int) -> tuple:
    """The rule of the fifty-fifth and fifty-seventh stages between ``build(False)`` (A) and ``build(True)`` (B): B
    ships if its median raw RMS over ``esp_forms`` is below A's by more than ``gain`` (deg), its median over
    ``gyro_forms`` not above A's by more than ``gain``, and it is worse than A by more than ``worse_deg`` (deg) on at
    most ``worse_logs`` of all the logs. Returns ``(B ships, {choice: (raw RMS per ESP form, per gyro form)
    (deg)})``."""
    errs = {c: (log_errors(build(c), esp_forms), log_errors(build(c), gyro_forms)) for c in (False, True)}
    (a1, a2), (b1, b2) = errs[False], errs[True]
    worse = int(np.sum(np.array(b1 + b2) > np.array(a1 + a2) + worse_deg))
    ships = np.median(b1) < np.median(a1) - gain and np.median(b2) <= np.median(a2) + gain and worse <= worse_logs
    return bool(ships), errs


def rounded_logs(logs, steps: dict, rate: float = UPSAMPLED_RATE_HZ, scoring=KITTI_SCORING) -> list:
    """``logs`` (:func:`training_logs`) as a logger that interpolates every channel linearly onto a ``rate`` (Hz) grid
    and writes it rounded to ``steps`` (``{channel: grid step}``, the channel's unit; a channel not named is written
    as it is) writes them; the reference roll (rad) linear onto the same grid; the scored samples recomputed with
    ``scoring``."""
    out = []
    for s, ref, _ in logs:
        t = _grid(s.t, rate)
        chans = {c: np.interp(t, s.t, getattr(s, c)) for c in s.channels if c != "t"}
        chans = {c: np.round(x / steps[c]) * steps[c] if c in steps else x for c, x in chans.items()}
        up = Signals(t=t, **chans, fixed=s.fixed, unbiased=s.unbiased)
        out.append((up, np.interp(t, s.t, ref), masks(up.t, up.vx, scoring)[1]))
    return out


def quiet_noise_sets(scale: float, cars=SIM_CARS, n=SIM_DRIVES) -> list:
    """``roadbank tune``'s training drives (seed 0) of each car in ``cars`` (:func:`simulated_sets`' drives) with the
    noise of the ESP yaw-rate sensor and accelerometer ``scale`` (-) times the data sheet's, their resolution kept."""
    cfg = SensorConfig()
    cfg = dataclasses.replace(cfg, yaw_rate=dataclasses.replace(cfg.yaw_rate, noise_std=cfg.yaw_rate.noise_std * scale),
                              ay=dataclasses.replace(cfg.ay, noise_std=cfg.ay.noise_std * scale))
    return [drive_set("train", n, 0, load_vehicle(car).params, sensors=cfg) for car in cars]


def choose_source_rounding(esp_logs, gyro_logs, esp_forms, gyro_forms, guard_forms, guard_sims) -> tuple:
    """The fifty-seventh stage (docs/estimators.md): ``kinematic-pif`` as ``roadbank estimate`` runs it (designed for
    each log, behind the online offset learner) with :data:`roadbank.vehicle.conditions.SOURCE_ROUNDING` False (A, as
    shipped before) and True (B), on the KITTI training drives interpolated and rounded (:func:`rounded_logs`) with
    their ESP channels alone (``esp_forms``) and with their roll rate (``gyro_forms``). Returns ``(chosen, {choice:
    (raw RMS per ESP form, per gyro form) (deg)})``. The drives as recorded (``esp_logs``, ``gyro_logs``), the other
    forms of ``guard_forms`` (lists of logs) and the simulated drives of ``guard_sims`` (lists of drive sets) must give
    the same outputs under both: a ValueError where they do not."""
    def build(choice):
        at = _with_settings(source_rounding=choice)
        return lambda s: with_online_offsets(at(s))

    kept = [s for s, _, _ in esp_logs + gyro_logs + [f for form in guard_forms for f in form]]
    kept += [d.signals for sets in guard_sims for drives in sets for d in drives]
    same_outputs(build, kept, (False, True), "a log that is not rounded between its source's samples was read "
                                             "otherwise: the stage's guard fails")
    return esp_and_gyro_rule(build, esp_forms, gyro_forms, SOURCE_ROUNDING_GAIN_DEG, SOURCE_ROUNDING_WORSE_DEG,
                             SOURCE_ROUNDING_WORSE_LOGS)


def gyro_sim_sets(offset: float, cars=SIM_CARS, n=SIM_DRIVES) -> list:
    """``roadbank tune``'s training drives (seed 0) of each car in ``cars`` (:func:`simulated_sets`' drives, every
    other channel as there) with a roll-rate gyro of the ESP yaw-rate sensor's class added: noise 0.1 deg/s,
    resolution 0.3 deg/s, offset ``offset`` (rad/s)."""
    gyro = ChannelErrorModel(noise_std=ESP_R_NOISE, resolution=ESP_R_RESOLUTION, bias=offset)
    return [drive_set("train", n, 0, load_vehicle(car).params, sensors=SensorConfig(roll_rate=gyro)) for car in cars]


def choose_quiet_gyro(kitti_gyro_logs, sim_gyro_sets) -> tuple:
    """The fifty-sixth stage (docs/estimators.md): ``kinematic-pif`` as ``roadbank estimate`` builds it (designed for
    each log, behind the online offset learner) with :data:`roadbank.vehicle.conditions.QUIET_READS_ROLL_RATE` False
    (A, shipped before) and True (B), on ``sim_gyro_sets`` (a list, per roll-rate offset, of :func:`gyro_sim_sets`).
    Returns ``(chosen, {choice: objective deg}, {choice: [per offset: per car: bank RMS per drive]})``. The KITTI
    training drives with their roll rate (``kitti_gyro_logs``, loud) must give the same outputs under both: a
    ValueError where they do not."""
    def build(choice):
        at = _with_settings(quiet_reads_roll_rate=choice)
        return lambda s: with_online_offsets(at(s))

    for s, _, _ in kitti_gyro_logs:
        a, b = (build(c)(s).run(s).theta for c in (False, True))
        if not np.array_equal(a, b):
            raise ValueError("a loud log got another design: the stage's guard fails")
    errs = {c: [sim_errors(build(c), sets) for sets in sim_gyro_sets] for c in (False, True)}
    obj = {c: float(np.mean([cars_median(e) for e in errs[c]])) for c in (False, True)}
    return bool(obj[True] <= obj[False] + QUIET_GYRO_LOSS_DEG), obj, errs


def choose_noise_octave(logs, up, resampled, sim_sets, choices=NOISE_OCTAVES) -> tuple:
    """The twenty-first stage (module docstring): the eighteenth stage's rule over ``choices``
    (:data:`roadbank.vehicle.conditions.NOISE_OCTAVE` values, the shipped first), on the KITTI training ``logs``, the
    same interpolated (``up``, :func:`upsampled_logs`) and resampled (``resampled``, :func:`resampled_logs`), and the
    simulated training drives ``sim_sets``. Returns ``(chosen, {choice: real scores}, {choice: simulated scores})``,
    the simulated ones for the shipped choice and the candidates within :data:`TIE_DEG` of the best real median."""
    return _roads_then_guarded({c: _with_settings(noise_octave=c, noise_octave_top=2.0) for c in choices},
                               logs + up + resampled, sim_sets)         # one octave, as it ran: the twenty-second


def prior_candidates(rates=BANK_RATES_DEG, kappas=KAPPAS) -> dict:
    """``{(bank rate deg/s, kappa): build}`` of the twenty-third stage: the shipped pair, then every other pair of
    ``rates`` x ``kappas`` in the grid's order; ``kinematic-pif`` built as the command line does."""
    shipped = (round(math.degrees(KINEMATIC_PIF_BANK_RATE), 6), KINEMATIC_PIF_KAPPA)
    keys = [shipped] + [k for k in itertools.product(rates, kappas) if k != shipped]
    return {(b, k): per_log("kinematic-pif", bank_rate=math.radians(b), kappa=k) for b, k in keys}


def choose_prior_again(logs, up, resampled, loud, cands: dict | None = None) -> tuple:
    """The twenty-third stage (module docstring): the eighteenth stage's rule over ``cands`` (default
    :func:`prior_candidates`) on the KITTI training ``logs``, the same interpolated (``up``, :func:`upsampled_logs`)
    and resampled (``resampled``, :func:`resampled_logs`), and the loud simulated drives ``loud`` (:func:`loud_sets`).
    Returns ``(chosen pair, {pair: real scores}, {pair: simulated scores})``, the simulated ones for the shipped pair
    and the candidates within :data:`TIE_DEG` of the best real median."""
    return _roads_then_guarded(prior_candidates() if cands is None else cands, logs + up + resampled, loud)


def choose_by_roads(builds: dict, logs, sim_sets) -> tuple:
    """The real-roads-first rule (module docstring) over ``builds`` (``{key: build}``, see
    :func:`objective`). Returns ``(chosen key, {key: real median}, {key: simulated median})``; the
    simulated median is computed for the candidates within :data:`TIE_DEG` of the best real one only;
    of candidates equal on both to :data:`EQUAL_DEG` (float rounding, e.g. the lowest speeds on
    simulated drives that never slow down), the first in ``builds``' order wins."""
    real = {k: objective(b, logs, []) for k, b in builds.items()}
    best = min(real.values())
    tied = [k for k, v in real.items() if v <= best + TIE_DEG]
    sim = {k: objective(builds[k], [], sim_sets) for k in tied}
    return min(tied, key=lambda k: (round(sim[k] / EQUAL_DEG), round(real[k] / EQUAL_DEG))), real, sim


#: the stages of :func:`kinematic_pif_candidates` over one setting: stage -> (the setting, its candidates, the
#: settings as they were before that stage)
_ONE_SETTING: dict[int, tuple[str, tuple, dict[str, Any]]] = {
    3: ("quiet_ratio", QUIET_RATIOS, {"quiet_filter": "pif-modified", **_NO_LEAD}),
    4: ("quiet_filter", QUIET_FILTERS, _NO_LEAD), 5: ("v_min", V_MINS, _NO_LEAD),
    6: ("lead_samples", LEADS_SAMPLES, _STATIC_CAR), 8: ("car_margin", CAR_MARGINS, _LINEAR),
    10: ("clip", CLIPS, _DESIGN_NOISE), 12: ("noise_tau", NOISE_TAUS, _ONE_RATIO),
    13: ("limit_tau", LIMIT_TAUS, _TIME_RATE), 14: ("bank_speed_exp", BANK_SPEED_EXPS, {}),
}


def kinematic_pif_candidates(stage: int, bank_rate_deg: float | None = None, kappa: float | None = None) -> dict:
    """``{key: build}`` of ``kinematic-pif`` candidates for :func:`choose_by_roads` (module docstring).

    ``stage`` 1: every ``(bank rate deg/s, kappa)`` of :data:`BANK_RATES_DEG` x :data:`KAPPAS`, the
    gate as shipped; ``stage`` 2: every ``(gate_on, gate_span, gate_release)`` of :data:`GATE_GRID`
    at ``bank_rate_deg`` and ``kappa`` (the first stage's choice); neither is quiet on any log
    (``quiet_ratio=0``: they ran before that). ``stage`` 3: every quiet ratio of
    :data:`QUIET_RATIOS`, in increasing order, with the shipped constants of the first two and the
    default PIF on a quiet log; ``stage`` 4: every filter of :data:`QUIET_FILTERS` on a quiet log, in
    that order, with the shipped constants of the first three; ``stage`` 5: every lowest speed of
    :data:`V_MINS`, highest first; ``stage`` 6: every sampled-data lead of :data:`LEADS_SAMPLES`, in
    that order (the continuous-time filter first); ``stage`` 8: every car margin of :data:`CAR_MARGINS`
    (the static car first: :func:`roadbank.vehicle.design_car`); ``stage`` 10: every limit of the low-pass's
    update of :data:`CLIPS` (the linear low-pass first); ``stage`` 12: every time constant of the running
    noise estimate of :data:`NOISE_TAUS` (none first; :func:`choose_noise_tau`); ``stage`` 13: every time
    constant of the shorter one the limit reads, :data:`LIMIT_TAUS` (the gain's first). Stages 1-5 ran before the
    sixth existed: their candidates have no lead (``lead_samples=0``); stages 1-7 before the eighth: a car not
    described is the static one (``car_margin=inf``); stages 1-9 before the tenth: the low-pass is linear
    (``clip=0``); stages 1-11 before the twelfth: no running noise (``noise_tau=0``); stages 1-12 before the
    thirteenth: the limit reads the gain's ratio (``limit_tau=0``).
    Every stage scores the real drives with :data:`~roadbank.validation.kitti.KITTI_SCORING`
    (:func:`training_logs`' default).
    """
    if stage == 1:
        return {(b, k): per_log("kinematic-pif", bank_rate=float(np.radians(b)), kappa=k, quiet_ratio=0.0,
                                **_NO_LEAD) for b in BANK_RATES_DEG for k in KAPPAS}
    if stage in _ONE_SETTING:
        key, values, before = _ONE_SETTING[stage]
        return {v: per_log("kinematic-pif", **{key: v}, **before) for v in values}
    if stage != 2 or bank_rate_deg is None or kappa is None:
        raise ValueError("kinematic_pif_candidates: stage 1, 3, 4, 5, 6, 8, 10, 12, 13 or 14, or stage 2 with the "
                         "first stage's bank rate and kappa")
    return {(on, sp, rel): per_log("kinematic-pif", bank_rate=float(np.radians(bank_rate_deg)), kappa=kappa,
                                   gate_on=on, gate_span=sp, gate_release=rel, **_NO_LEAD)
            for on in GATE_GRID["gate_on"] for sp in GATE_GRID["gate_span"] for rel in GATE_GRID["gate_release"]}


def long_logs(logs, gap: float = LONG_GAP_S) -> list:
    """The drives of ``logs`` (:func:`training_logs`) put end to end, ``gap`` s apart, in their order and in the
    reverse: a long drive that changes roads after the minute it is designed on, starting on either end. Each
    is ``(signals, [(first sample, samples, reference roll rad, scored mask)] per drive)``."""
    out = []
    for order in (list(range(len(logs))), list(range(len(logs)))[::-1]):
        parts, spans, t0, first = [], [], 0.0, 0
        for i in order:
            s, ref, m = logs[i]
            t = np.asarray(s.t, dtype=np.float64) - s.t[0] + t0
            parts.append(Signals(t, s.vx, s.ay, s.r, s.delta_f))
            spans.append((first, len(s), ref, m))
            first, t0 = first + len(s), t[-1] + gap
        out.append((concat_signals(parts), spans))
    return out


def long_errors(build, long) -> list[float]:
    """The raw RMS error (deg) of ``theta`` against the INS roll on each drive's scored samples, for every drive of
    every long log of ``long`` (:func:`long_logs`), the long log run as one (``build(signals)`` designed for it as
    the command line does: on its first minute)."""
    errs = []
    for signals, spans in long:
        theta = build(signals).run(signals).theta
        for first, n, ref, m in spans:
            errs.append(rms_deg(theta[first:first + n][m], ref[m]))
    return errs


def long_median(build, long) -> float:
    """Median (deg) of :func:`long_errors`."""
    return float(np.median(long_errors(build, long)))


def choose_noise_tau(logs, long=None, stage: int = 12) -> tuple[float, dict]:
    """The twelfth stage: the time constant of :data:`NOISE_TAUS` for ``kinematic-pif``'s running noise estimate
    (``stage`` 13: of :data:`LIMIT_TAUS` for the shorter one its limit reads; 14: the exponent of the speed in the
    bank-rate prior, :data:`BANK_SPEED_EXPS`). Each candidate's objective is the KITTI training median (drive by
    drive, :func:`objective` without simulated drives: every one is quiet, so the low-pass is not used there) plus
    :func:`long_median` over ``long`` (default :func:`long_logs` of ``logs``); the lowest wins, ties within
    :data:`TIE_DEG` going to the earlier candidate. From the fourteenth stage on, a candidate other than the first
    wins only where the mean of the same drive scores (the drives one by one and every drive of the long logs) is
    lower than the first's too (module docstring); else the first stays. Returns ``(chosen, {candidate: (drive
    median, long median)})``."""
    long = long_logs(logs) if long is None else long
    cands = kinematic_pif_candidates(stage)
    errs = {k: (log_errors(b, logs), long_errors(b, long)) for k, b in cands.items()}
    scores = {k: (float(np.median(a)), float(np.median(b))) for k, (a, b) in errs.items()}
    best = min(a + b for a, b in scores.values())
    chosen = next(k for k in cands if sum(scores[k]) <= best + TIE_DEG)
    if stage >= 14:
        chosen = guarded(chosen, next(iter(cands)), {k: float(np.mean(np.concatenate(e))) for k, e in errs.items()})
    return chosen, scores


def smoother_clip_candidates() -> dict:
    """``{clip: build}`` of ``kinematic-smoother`` over :data:`CLIPS` (the linear smoother first), each
    designed for the log as the command line does (the log's noise measures the limit), for
    :func:`choose_by_roads`: the eleventh stage, the limit of the offline default's two passes."""
    return {c: within(per_log("kinematic-smoother", clip=c), **BEFORE_64) for c in CLIPS}


def _quiet_by(measure: str):
    """``build`` of the default for a log whose car is not described, quiet as ``measure`` reads it."""
    def build(signals):
        measured = vehicle.log_conditions(signals)
        cond = {**measured, "log_ay_floor": None} if measure == "mean" else measured
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            car = vehicle.undescribed_params(signals, cond=measured)
            return vehicle.for_conditions("kinematic-pif", cond, car, **_LINEAR)
    return build


def paper_sets(cars=SIM_CARS, seeds=PAPER_SEEDS) -> list:
    """The paper's scenarios (nominal) of each shipped car in ``cars`` at each noise seed: simulator results."""
    return [run_scenario(sc, plant=PlantParams(vehicle=load_vehicle(car).params), seed=seed)
            for car in cars for sc in SCENARIOS for seed in seeds]


def paper_median(build, runs) -> float:
    """Median over ``runs`` (:func:`paper_sets`) of the RMS error (deg) of ``theta`` after the first 5 s."""
    errs = []
    for res in runs:
        s = res.signals
        m = np.asarray(s.t) >= s.t[0] + 5.0
        errs.append(rms_deg(build(s).run(s).theta[m], res.truth.theta[m]))
    return float(np.median(errs))


def choose_quiet_measure(logs, sim_sets, runs) -> tuple[str, dict]:
    """The ninth stage: the measure of :data:`QUIET_MEASURES` that the quiet decision reads. The rule's objective
    (:func:`objective`: the KITTI training median plus the simulated median, cars not described) first; where
    the two are within :data:`TIE_DEG`, the lower :func:`paper_median` over ``runs``; equal to
    :data:`EQUAL_DEG` as well: the first (the stages before). Returns ``(measure, {measure: (objective,
    paper median)})``."""
    obj = {m: objective(_quiet_by(m), logs, sim_sets) for m in QUIET_MEASURES}
    best = min(obj.values())
    tied = [m for m in QUIET_MEASURES if obj[m] <= best + TIE_DEG]
    paper = {m: paper_median(_quiet_by(m), runs) for m in tied}
    chosen = min(tied, key=lambda m: round(paper[m] / EQUAL_DEG))
    return chosen, {m: (obj[m], paper.get(m, math.nan)) for m in QUIET_MEASURES}
