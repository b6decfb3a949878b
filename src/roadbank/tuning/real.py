r"""Choices made on training data: the cut-off and feed-forward gain of ``kinematic-lp`` / ``kinematic-ff``.

The rule: for each candidate ``(cutoff, kappa)`` of a fixed grid,

* **real roads**: run the estimator on every KITTI *training* drive
  (:data:`roadbank.validation.splits.KITTI_TRAINING`) and take the raw RMS error (deg) of
  ``theta`` against the INS roll on the scored samples (:data:`roadbank.validation.kitti.KITTI_SCORING`:
  vx >= 5 m/s after the drive's first 5 s, the seconds after each stop included, no offset: how the
  real-road target is stated); median over the drives;
* **simulated drives, car not described**: ``roadbank tune``'s *training* drive set
  (:func:`roadbank.tuning.drive_set`, seed 0, :data:`SIM_DRIVES` drives) for each shipped car
  (:data:`SIM_CARS`), the estimator built without the car (default parameters); bank RMS error
  (deg) per drive as ``roadbank tune`` scores it; the median per car, then the median over the cars.

The objective is the sum of the two medians (deg): real roads and simulated manoeuvres of cars
nobody described weigh the same. The chosen candidate has the lowest objective, ties within
:data:`TIE_DEG` going to the smaller ``kappa`` and then the smaller cut-off (the simpler,
smoother filter). ``kinematic-lp`` is the best with ``kappa = 0``, ``kinematic-ff`` the best over
the whole grid. Neither the KITTI validation drives nor ``roadbank tune``'s validation set take part.

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

The twenty-fourth stage (:func:`choose_gyro`; rule written 2026-12-05 before any candidate ran) is for a log that
carries a roll rate (:attr:`roadbank.Signals.p`: an INS, a phone, a six-axis IMU), which no stage before read. It
chooses the cross-over and the offset time constant of ``kinematic-gyro`` (:mod:`roadbank.estimators.gyro`) over
:data:`GYRO_CUTOFFS_HZ` x :data:`GYRO_BIAS_TAUS` (0: no offset state), and then whether ``kinematic-gyro`` is the
default on such a log. Real sets (:func:`gyro_sets`): the KITTI training drives as read (the INS compensates its
gyro's offset) and the same drives with a constant roll-rate offset of +:data:`GYRO_OFFSET_DEG` and of
-:data:`GYRO_OFFSET_DEG` deg/s added (a MEMS gyro's, the range the campaign draws for the yaw rate). Objective: the
mean over the three sets of the median raw RMS (the scoring of every stage). The lowest wins; ties within
:data:`TIE_DEG` go to fewer states (no offset state), then to the longer offset time constant, then to the lower
cross-over (the smoother filter). ``kinematic-gyro`` as chosen is then the default on a log with a roll rate if its
objective is lower than that of the default as shipped (``kinematic-pif`` designed for each log, which reads no roll
rate, so its three medians are one). No simulated set takes part: ``roadbank tune``'s drives last 15-25 s, shorter
than an offset can be learnt in, and their sensors are an ESP cluster's. Neither the KITTI validation drives nor
comma2k19 take part.

The twenty-fifth stage (:func:`choose_gyro_map`; rule written 2026-12-05 before it ran, after the twenty-fourth was
committed) asks the same of ``roadbank map``'s default: whether on a loud log with a roll rate it is
``kinematic-gyro-smoother`` (``kinematic-gyro`` forward and backward, averaged; the twenty-fourth stage's cross-over
and offset time constant, no grid of its own), by the twenty-fourth stage's objective on its three real sets,
against the map's default as shipped (``kinematic-smoother`` built for each log, without the roll rate).

The twenty-sixth stage (:func:`choose_grade`; rule written 2026-12-05 before it ran, after an exploratory script on
the training drives alone showed that the INS's own pitch takes their median from 0.249 to 0.225 deg) corrects the
roll rate for the grade: the rate of the roll angle is :math:`p + (q \sin\theta + r \cos\theta) \tan\vartheta
\approx p + r \tan\vartheta` with :math:`\vartheta` the pitch (positive nose down), which a log with a
longitudinal accelerometer gives: :math:`\sin\vartheta = (\dot v_x - a_x)/g`, averaged causally over a window of
:math:`W` s (:mod:`roadbank.models.attitude`). Candidates: :data:`GRADE_WINDOWS_S` (0: no
correction), each ``kinematic-gyro`` with the twenty-fourth stage's cross-over and offset time constant (no grid of
its own). Real sets and objective: the twenty-fourth stage's (:func:`gyro_sets`, :func:`gyro_objective`), the drives
read with their ``ax``. The lowest wins; ties within :data:`TIE_DEG` go to no correction, then to the longer window.
The correction is then used wherever ``kinematic-gyro`` (and its smoother) runs on a log with a usable ``ax``
(:func:`roadbank.vehicle.conditions.log_conditions`: the slope of ``vx`` on the integrated ``ax``, band-passed as
the roll rate's, within the roll rate's range; not chosen, stated). No simulated set (a flat road: nothing to
correct); neither the KITTI validation drives nor comma2k19 take part.

The twenty-seventh stage (:func:`choose_gyro_stops`; rule written 2026-12-05 before any candidate ran) asks how
``kinematic-gyro`` passes a stop. As shipped it stops below ``v_min`` = 1 m/s like the kinematic family, and a gap
of more than ``max_gap`` = 1 s between usable samples restarts it from one sample of the kinematic estimate with no
offset learnt: after every stop at a traffic light. At rest the kinematic estimate is ``ay/g`` alone (no cornering,
no road vibration) and the gyro reads its offset, so the filter may run through a stop (``v_min`` 0.05 m/s; the rule
said 0, amended before any candidate ran when the estimators refused a ``v_min`` of 0; a speed at rest that reads
below it, an INS's -0.1 m/s, is still held); or it may hold
its state through a stop and go on from it (a longer ``max_gap``: a car at rest keeps its roll). Candidates:
:data:`GYRO_V_MINS` x :data:`GYRO_MAX_GAPS`, ``kinematic-gyro`` with the twenty-fourth to twenty-sixth stages'
constants; the twenty-fourth stage's real sets and objective (the drives with their ``ax``). The lowest wins; ties
within :data:`TIE_DEG` go to the shipped pair (1 m/s, 1 s), then to the higher ``v_min``, then to the shorter
``max_gap``. ``kinematic-gyro-smoother`` takes the same pair (its forward and backward passes are that filter).
Neither the KITTI validation drives nor comma2k19 take part.

The twenty-eighth stage (:func:`choose_gyro_order`; rule written 2026-12-05 before any candidate ran) asks for the
order of ``kinematic-gyro``'s complementary filter. On the training drives as read, its error above 0.5 Hz is
0.09-0.21 deg: the road's vibration in the kinematic estimate, which the shipped filter (order 2) passes falling at
20 dB a decade above its cross-over. Order 4 puts all four poles at :math:`\omega = 2\pi f`: the kinematic
estimate's path :math:`(6\omega^2 s^2 + 4\omega^3 s + \omega^4)/(s + \omega)^4` falls at 40 dB a decade, and
the roll rate's path :math:`s^2 (s + 4\omega)/(s + \omega)^4` (its complement over :math:`s`) still rejects a
constant gyro offset. Candidates: the shipped filter, and order 4 at each :math:`f` of
:data:`GYRO_ORDER4_CUTOFFS_HZ`; the grade correction and the stop handling as shipped; the twenty-fourth stage's
real sets and objective. The lowest wins; ties within :data:`TIE_DEG` go to the shipped filter, then to the lower
:math:`f`. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The twenty-ninth stage (:func:`choose_gyro_sideslip`; rule written 2026-12-05 before any candidate ran) asks whether
``kinematic-gyro`` takes the sideslip acceleration out of the kinematic estimate. :math:`k = \sin\theta +
\dot v_y / g`, and the gyro does not see :math:`\dot v_y`, so what of it the kinematic estimate's path passes is
error, largest at turn entries in town (:math:`L_r \dot r` of 0.3 m/s^2 is 1.7 deg in :math:`k`). The rear axle's
quasi-static balance gives it without steering: :math:`v_y = L_r r - c\, v_x a_y`, :math:`c = m L_f / (C_r L)`, so
:math:`\dot v_y \approx L_r \dot r - c\, v_x \dot a_y` (:math:`v_x` the schedule, held), with the car the
estimator is built for (a log's fitted car, as the command line builds it). Candidates: ``"none"`` (shipped),
``"geometry"`` (:math:`L_r \dot r` alone, :math:`c = 0`), ``"quasi-static"`` (both terms); the earlier stages'
constants; the twenty-fourth stage's real sets and objective, each drive's estimator built for its own fitted car
(:func:`roadbank.vehicle.undescribed_params`). The lowest wins; ties within :data:`TIE_DEG` go to ``"none"``, then
``"geometry"``. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take
part.

The thirtieth stage (:func:`choose_roll_check`; rule written 2026-12-05 before any candidate ran) asks how the check
that a log's roll rate follows its ``ay`` (:func:`roadbank.vehicle.conditions.roll_rate_slope`) decides on a short
log. Many raw drives last 10-30 s; there the shipped check (centred means over 1 s and 10 s, slope within 0.5-2)
often cannot decide (fewer than about 11 s at speed: no slope) or reads 0.4-2 on a good gyro, and the default falls
back to the ESP blend. Pieces: each KITTI training drive cut into consecutive whole pieces of each of
:data:`CHECK_PIECES_S`. Candidates: the windows of :data:`CHECK_WINDOWS_S` x the ranges of :data:`CHECK_RANGES`. For
each piece: the default as the command line builds it with the roll rate accepted (``kinematic-gyro``) and without
(the ESP default), each for the piece's fitted car; a candidate takes the first where its check accepts the piece's
roll rate, else the second. Objective: the mean over the piece lengths of the median raw RMS over the pieces (the
KITTI scoring within each piece). Constraint: a candidate that accepts, on any piece, the piece's roll rate negated,
the yaw rate in its place, or the roll rate in deg/s read as rad/s is out. The lowest objective wins; ties within
:data:`TIE_DEG` go to the shipped check, then to the longer windows, then to the narrower range. Neither the KITTI
validation drives nor comma2k19 take part.

The thirty-first stage (:func:`choose_roll_check_again`; rule written 2026-12-05 before any candidate ran, after the
thirtieth found every check accepting the yaw rate in the roll rate's place on some short piece, so that the
shipped check stayed by default): the thirtieth stage's pieces, objective and candidates, each also with a second
condition, that the roll rate is not the yaw rate: the magnitude of the correlation of the two channels over the
design span's samples at speed below :data:`CHECK_MAX_CORR` (two gyros about different axes; a plausibility bound,
not tuned). Constraint: the thirtieth stage's three wrong channels and a fourth, the INS's pitch rate (``wy``) in the
roll rate's place (a gyro about the wrong horizontal axis, as a phone turned in its mount gives): a candidate that
accepts any on any piece is out. Ties as the thirtieth stage's, then without the second condition. Where none meets
the constraint, the shipped check stays. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-second stage (:func:`choose_short_check`; rule written 2026-12-05 before any candidate ran, after the
thirty-first, and after reading on the thirtieth stage's rows that on the ten 12-s training pieces where the shipped
check gives no slope the gyro's error is below the ESP default's on all ten, medians 0.36 and 0.52 deg): a second
check for the logs too short for the first. Candidates: the shipped check alone; and the shipped check where it gives
a slope, else a fallback with centred means over :data:`SHORT_CHECK_WINDOWS_S` (0.5 s and 4 s), the slope within
each of :data:`CHECK_RANGES`, and the thirty-first stage's second condition (the roll rate not the yaw rate). In each
candidate the ``ax`` check (:func:`roadbank.vehicle.conditions.ax_slope`) takes the same windows as the roll-rate
check (as shipped: the same band), fallback included, without the second condition. Pieces: the training drives cut
as the thirtieth stage's, into :data:`SHORT_PIECES_S` (8, 12 and 20 s). For each piece: the default as the command
line builds it for the piece's fitted car with the roll rate and ``ax`` accepted, with the roll rate alone, and the
ESP default; a candidate takes the one its checks give. Objective: the thirtieth stage's (mean over the lengths of
the median raw RMS). Constraint: a candidate that accepts on any piece a wrong roll rate (the thirtieth stage's three:
negated, the yaw rate in its place, deg/s read as rad/s) or a wrong ``ax`` (negated, in g read as m/s^2, ``ay`` in its
place) is out. The pitch rate in the roll rate's place is counted and reported but is no constraint: the shipped
check accepts the negated pitch rate on 4 of the 16 whole drives (the thirty-first stage), so no candidate here can
guard it, and a map must name the roll axis. The lowest objective wins; ties within :data:`TIE_DEG` go to the shipped
check, then to the narrower range. Logs on which the shipped check gives a slope (every whole training and
validation drive) are the same under every candidate. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-third stage (:func:`choose_fixed_channels`; rule written 2026-12-05 before any candidate ran, after the
thirty-second kept the shipped check: every candidate, the shipped one too, accepted a wrong channel on some piece,
though the fallback's objectives were lower, 0.265 and 0.251 against 0.303 deg): where the log's format itself fixes
what an optional channel is, there is no map to get wrong. The readers of KITTI's OXTS files and of comma2k19 name the
roll rate and ``ax`` from the format's documentation (``Signals.fixed``); a user's map (CSV, MDF, CAN, ROS) does not,
and its channels are judged by the checks as before under every candidate. Candidates for a format's channel:
``"judged"`` (shipped: used only where its check accepts it); ``"undecided"`` (where its check cannot decide because
the log has too few samples at speed for the check's band, it is used; a channel whose integral never moves is not);
``"always"`` (used whatever its check reads). Pieces and rows: the thirty-second stage's (KITTI's OXTS is such a
format); each candidate takes, per piece, the default with the roll rate and ``ax``, with the roll rate alone, or
neither, as its rule for the two channels gives. Objective: the thirtieth stage's. No wrong-channel constraint: no
map is read. The lowest wins; ties within :data:`TIE_DEG` go to ``"judged"``, then ``"undecided"``. Neither the KITTI
validation drives nor comma2k19 take part.

The thirty-fourth stage (:func:`choose_gyro_start`; rule written 2026-12-05 before any candidate ran, after reading on
the training drives that the gyro filter's offset state absorbs part of its start error: their first 8 s score 0.256
with it and 0.193 without it, bias_tau 0, whole drives 0.229 and 0.221 as read; the twenty-fourth stage kept the
offset state for gyros that have an offset): the offset state held at zero for the first ``start_hold`` seconds after
the log's first valid sample, learning after. Candidates: ``start_hold`` in :data:`GYRO_START_HOLDS_S` (0, shipped;
2, 5, 10 s). Sets: the twenty-fourth stage's three (the training drives as read and with a roll-rate offset of
+-0.3 deg/s), each whole and cut into the thirty-second stage's pieces (8, 12, 20 s, each run from a reset, the
KITTI scoring within it). Estimator: ``kinematic-gyro`` with the shipped constants and the grade window (as the
twenty-sixth to twenty-ninth stages ran it). Objective: the mean over the three sets of the mean over the four
lengths (whole, 8, 12, 20 s) of the median raw RMS. The lowest wins; ties within :data:`TIE_DEG` go to the shorter
hold. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-fifth stage (:func:`choose_gyro_kalman_start`; rule written 2026-12-05 before any candidate ran, after the
thirty-fourth kept learning the offset from the start, and after reading on validation drive 0070 only that the start's
Kalman filter runs and that its offset moves faster early than the shipped filter's: 0.84 against 0.27 deg/s at 4 s,
with the prior 0.3 deg/s; no error against its INS was computed): the start as the Kalman filter of the complementary
filter's own model (:mod:`roadbank.estimators.gyro_start`: the state after each sample that filter's for ``start_span``
s after each (re)start; its steady state is the shipped filter). Candidates: none (``start_span`` 0, shipped); and
``start_span`` :data:`GYRO_START_SPAN_CANDIDATE_S` (20 s, 2 T_b: by then the start filter's gains are within 4 % of
their steady values at 10 Hz for every prior here) with the offset's prior ``start_offset`` in
:data:`GYRO_START_OFFSETS_DEG` (0.03, 0.1, 0.3, 1 deg/s; the noise per sample fixed at 1 deg, only the ratio matters).
Sets, pieces, estimator and objective: the thirty-fourth stage's. The lowest wins; ties within :data:`TIE_DEG` go to
none, then to the smaller prior. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor
comma2k19 take part.

The thirty-sixth stage (:func:`choose_unbiased_gyro`; rule written 2026-12-05 before any candidate ran, after the
thirty-fifth kept the steady start, knowing from the thirty-fourth's rule that on the training drives as read the
filter without an offset state scores 0.193 deg on their first 8 s against 0.256, whole drives 0.221 against 0.229):
a roll rate whose source documents it as free of offset. KITTI's OXTS files are the outputs of an RT3003 INS, whose
own Kalman filter applies its gyro bias and scale-factor corrections to the angular rates it outputs (and its bias
corrections to the accelerations; the RT3000 manual); the reader of those files says so (``Signals.unbiased``), a
phone's raw gyro (comma2k19) or a user's map does not. For such a roll rate the twenty-fourth stage's guard against
an offset (its sets with +-0.3 deg/s added) does not apply. Candidates: the twenty-fourth stage's grid
(:data:`GYRO_CUTOFFS_HZ` x :data:`GYRO_BIAS_TAUS`, bias_tau 0: no offset state), the shipped pair among them.
Estimator: ``kinematic-gyro`` with the grade window (as the thirty-fourth stage ran it). Set: the training drives as
read, whole and cut into the thirty-second stage's pieces (8, 12, 20 s, each from a reset). Objective: the mean over
the four lengths of the median raw RMS. The lowest wins; ties within :data:`TIE_DEG` go to the shipped pair, then to
the longer ``bias_tau`` (an offset state guards against a source that is wrong about itself), then to the higher
cut-off. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-seventh stage (:func:`choose_unbiased_start`; rule written 2026-12-05 before any candidate ran, after the
thirty-sixth chose 0.07 Hz and 40 s for such a roll rate, and after a test on the first 10 s of validation drive 0070
showed that filter keeping most of a 0.8 deg start error through those 10 s, 0.41 deg against the ESP default's 0.26):
the start of the filter for a roll rate documented free of offset. Candidates: none (shipped); the thirty-fifth
stage's Kalman start with ``start_span`` 2 T_b (80 s) and the offset's prior ``start_offset`` in
:data:`UNBIASED_START_OFFSETS_DEG` (0.03, 0.1, 0.3 deg/s). Estimator: ``kinematic-gyro`` with the thirty-sixth
stage's constants and the grade window. Set, pieces and objective: the thirty-sixth stage's (the training drives as
read, whole and in 8, 12, 20 s pieces). The lowest wins; ties within :data:`TIE_DEG` go to none, then to the smaller
prior. ``kinematic-gyro-smoother`` takes the result. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-eighth stage (:func:`choose_grade_start`; rule written 2026-12-05 before any candidate ran, after the
thirty-seventh, and after reading on the training drives that two of them start turning out of a steep place (0064:
pitch 5.3 deg, yaw rate -0.48 rad/s; 0034), where the integrated roll rate leaves the INS roll by 3.9 and 2.4 deg in
5-10 s, and that the INS's own pitch in :math:`p + r \tan\vartheta` removes it (0.05 and -0.08 deg), while the
shipped correction does not start before its 4 s window has passed and then lags): the pitch window and its start.
Candidates: ``grade_window`` :math:`W` in (1, 2, 4 s) and ``grade_first_span`` :math:`S` (before the log has lasted
:math:`W`, the pitch averages from the log's first sample once :math:`S` has passed) in (none, 0.5, 1, 2 s) with
:math:`S < W`: nine, the shipped (4 s, none) among them. Objective: the mean of the thirty-fourth stage's objective
(the shipped ``kinematic-gyro`` constants on its three sets, whole and in pieces) and the thirty-sixth stage's (the
unbiased constants on the training drives as read, whole and in pieces). The lowest wins; ties within
:data:`TIE_DEG` go to the shipped pair, then to the longer window, then to the longer first span. Both filters and
``kinematic-gyro-smoother`` take the result. Neither the KITTI validation drives nor comma2k19 take part.

The thirty-ninth stage (:func:`choose_pitch_rate`; rule written 2026-12-06 before any candidate ran, after reading
on the training drives, with scratch code, that the INS's own pitch in :math:`p + r \tan\vartheta` brings their
median from 0.191 to 0.179 deg (0064 0.403 -> 0.201, 0034 0.304 -> 0.245), the shipped pitch being 1.0-1.2 deg off
the INS's on those two, and that a pitch observer driven by the pitch rate, converted to the rate of the Euler pitch
with the kinematic roll, comes near it): the pitch from a pitch-rate gyro (``Signals.q``, KITTI's ``wy``). The
observer (:func:`roadbank.models.attitude.observed_pitch`): :math:`\dot{\hat v} = a_x + g \sin\hat\vartheta + k_1
(v_x - \hat v)`, :math:`\dot{\hat\vartheta} = q \cos\phi_k - r \sin\phi_k + k_2 (v_x - \hat v)`, :math:`k_1 =
2 \zeta \omega`, :math:`k_2 = \omega^2 / g`, :math:`\zeta = 0.7`, :math:`\phi_k` the kinematic roll
:math:`\arcsin((a_y - v_x r)/g)`, from :math:`\hat v = v_x`, :math:`\hat\vartheta = 0` at the log's first sample.
Candidates: the shipped pitch (the grade window, :math:`q` not read); the observer with bandwidth :math:`\omega` in
:data:`PITCH_BANDWIDTHS` (0.5, 1, 2 rad/s) x start in :data:`PITCH_STARTS` (none; 3 rad/s for the first 3 s) x use
(only for a pitch rate documented free of offset, ``Signals.unbiased``; for every pitch rate): thirteen. Sets and
objective: the thirty-eighth stage's (the mean of the thirty-fourth stage's objective, the shipped constants on its
three sets, and the thirty-sixth stage's, the unbiased constants on the drives as read; each whole and in 8, 12,
20 s pieces), the thirty-fourth stage's two offset sets carrying the same offset (+-0.3 deg/s) on :math:`q` as on
:math:`p` (a MEMS gyro's axes each have one) and counting as not documented free of offset. The lowest wins; ties
within :data:`TIE_DEG` go to the shipped pitch, then to the use for an unbiased pitch rate only, then to no start,
then to the lower bandwidth. Both filters and ``kinematic-gyro-smoother`` take the result. Neither the KITTI
validation drives nor comma2k19 take part; the stages before run on drives without their pitch rate, as they ran.

The fortieth stage (:func:`choose_pitch_start`; rule written 2026-12-06 before any of its candidates ran on it, after
the thirty-ninth chose 0.5 rad/s without a start for an unbiased pitch rate, and after a test on validation drive 0070
failed with that choice: the drive pulls away turning hard (0.66 rad/s) on a 3 deg grade, and the observer, started
at zero pitch, needs about 5 s to reach the pitch its accelerometer shows, which the window's first span (the
thirty-eighth stage) reads in 2 s; the thirty-ninth stage's training objective had the 3 s start within 0.0002 deg
of none): the observer's start. A zero pitch is a guess, not a reading. Candidates: ``pitch_start`` in
:data:`PITCH_START_CANDIDATES` (none; 3 rad/s for 3 s; 3 rad/s for 6 s; 6 rad/s for 3 s), the observer at
:data:`~roadbank.estimators.gyro.UNBIASED_PITCH_BANDWIDTH` for an unbiased pitch rate. Sets and objective: the
thirty-ninth stage's. The lowest wins; ties within :data:`TIE_DEG` go to a start over none (the reason above), then to
the shorter span, then to the lower start bandwidth. Neither the KITTI validation drives nor comma2k19 take part.

The forty-first stage (:func:`choose_pitch_bandwidth`; rule written 2026-12-06 before any of its candidates ran,
after the thirty-ninth chose the lowest bandwidth of its grid, 0.5 rad/s, whose edge it is): the observer's bandwidth
below that edge. Candidates: :data:`PITCH_BANDWIDTH_CANDIDATES` (0.25, 0.35, 0.5 rad/s), each with the fortieth
stage's start, for an unbiased pitch rate. Sets and objective: the thirty-ninth stage's. The lowest wins; ties within
:data:`TIE_DEG` go to the shipped 0.5 rad/s, then to the higher bandwidth. Neither the KITTI validation drives nor
comma2k19 take part.

The forty-second stage (:func:`choose_biased_pitch_rate`; rule written 2026-12-06 before any of its candidates ran,
after the forty-first): a pitch rate not documented free of offset (a MEMS gyro: a phone, an IMU). A constant offset
``b`` of it leaves :math:`2\zeta b/\omega` in the observer's pitch (0.84 deg for 0.3 deg/s at 0.5 rad/s; a phone's
1 deg/s, 2.8 deg), so the thirty-ninth stage read none. Candidates: none read (shipped); the observer with the
fortieth stage's start and an offset state learnt in ``T_q`` (:data:`PITCH_OFFSET_TAUS`: none, 20, 60 s; the error's
characteristic polynomial :math:`(s + 1/T_q)(s^2 + 2\zeta\omega s + \omega^2)`), for a pitch rate with an offset
only (an unbiased one keeps the shipped observer). Sets and objective: the thirty-ninth stage's, its offset sets
carrying +-0.3 deg/s on ``q`` as on ``p`` and now also +-1 deg/s on ``q`` alone (a phone's), the mean over the five
general sets. The lowest wins; ties within :data:`TIE_DEG` go to none read, then to the longer ``T_q``. Neither the
KITTI validation drives nor comma2k19 take part.

The forty-third stage (:func:`choose_unbiased_gyro_again`; rule written 2026-12-06 before any of its candidates ran,
after the forty-second): the thirty-sixth stage's constants for an unbiased roll rate were chosen with the window's
pitch; with the observer's, the roll rate's grade error is smaller and a lower cut-off may pay. Candidates: the
cut-offs :data:`UNBIASED_CUTOFFS_AGAIN_HZ` (0.03, 0.05, 0.07, 0.1 Hz) x offset time constants
:data:`UNBIASED_TAUS_AGAIN_S` (20, 40, 80 s), the shipped pair among them, each with the observer as shipped.
Objective: the thirty-sixth stage's (the training drives as read, whole and in 8, 12, 20 s pieces; the mean over the
four lengths of the median raw RMS). The lowest wins; ties within :data:`TIE_DEG` go to the shipped pair, then to the
longer time constant, then to the higher cut-off. Neither the KITTI validation drives nor comma2k19 take part.

The forty-fourth stage (:func:`choose_pitch_anchor`; rule written 2026-12-06 before any of its candidates ran, after
reading on the training drives, with scratch code, that the observer as shipped is 1-2.5 deg off the INS's pitch in its
first 2 s where a drive starts on a grade (0064, 0034, 0087: 5.3, -3.1, 2.1 deg), and that the INS's pitch put into the
observer's first sample takes 0064 from 0.308 to 0.235 deg and the 8 s pieces' median from 0.166 to 0.158): the
observer's start. Its first pitch is a guess (zero); the speed, ``ax`` and the pitch rate of the first seconds fix it:
integrated, :math:`v_x(t) = v_0 + \int a_x + g (\vartheta_0 \tau + \int\!\!\int \dot\vartheta_q)` with :math:`\tau` the
time since the first sample, linear in :math:`(v_0, \vartheta_0)`. The anchored start fits them by least squares on
every sample so far (:math:`\vartheta_0` with a prior: a grade of 3 deg standard deviation, a speed noise of 0.05 m/s,
stated not tuned) and gives :math:`\vartheta_0 + \int\dot\vartheta_q` for the first ``span`` s; the observer goes on
from there. Candidates: the shipped start (3 rad/s for 3 s from a zero pitch); the anchored start over
:data:`PITCH_ANCHOR_SPANS_S` (1, 2, 3 s) with no faster start after it; the anchored start over 1 s with the shipped 3
rad/s until 3 s. Sets and objective: the fortieth stage's, with the unbiased roll rate's constants as shipped since the
forty-third stage (0.05 Hz, 40 s). The lowest wins; ties within :data:`TIE_DEG` go to the shipped start, then to the
shorter span, then to no faster start after it. Neither the KITTI validation drives nor comma2k19 take part.

The forty-fifth stage (:func:`choose_unbiased_after_anchor`; rule written 2026-12-06 before any of its candidates ran,
after the forty-fourth chose the anchored start): the observer's first seconds were what a slow observer and a low
cut-off paid for (the forty-first stage had 0.25 rad/s the lowest, within the tie of 0.5, with the 3 rad/s start; the
forty-third traded 0070's start for the rest); with the first pitch fitted, both may be chosen again, together.
Candidates: the observer's bandwidth in :data:`ANCHORED_BANDWIDTHS` (0.25, 0.35, 0.5 rad/s) x the unbiased roll rate's
cut-off in :data:`ANCHORED_CUTOFFS_HZ` (0.03, 0.05, 0.07 Hz), the offset time constant 40 s and the anchored start as
shipped: nine, the shipped pair (0.5 rad/s, 0.05 Hz) among them. Objective: the thirty-sixth stage's (the training
drives as read, whole and in 8, 12, 20 s pieces; the mean over the four lengths of the median raw RMS), as the
forty-third's. The lowest wins; ties within :data:`TIE_DEG` go to the shipped pair, then to the higher bandwidth, then
to the higher cut-off. Neither the KITTI validation drives nor comma2k19 take part.

The forty-sixth stage (:func:`choose_unbiased_offset_again`; rule written 2026-12-06 before any of its candidates ran,
after the forty-fifth, and after reading on the training drives, with scratch code, that the shipped filter stays 0.2
deg below the INS roll on 0064 for 40 s after its start while the kinematic estimate low-passed at 0.05 Hz does not, and
that the whole drives' median at 0.05 Hz is 0.1632 deg without an offset state, 0.1658 with the shipped 40 s, 0.1638
with 160 s: the offset state learns the start's error and keeps it): the unbiased roll rate's offset state again, with
its cut-off. Candidates: the offset time constant in :data:`ANCHORED_BIAS_TAUS_S` (0: no offset state, 40, 80, 160 s) x
the cut-off in :data:`ANCHORED_CUTOFFS_HZ` (0.03, 0.05, 0.07 Hz), the observer as shipped: twelve, the shipped pair
(0.05 Hz, 40 s) among them. Objective: the thirty-sixth stage's (the training drives as read, whole and in 8, 12, 20 s
pieces; the mean over the four lengths of the median raw RMS). The lowest wins; ties within :data:`TIE_DEG` go to the
shipped pair, then to the longer offset time constant (none last: an offset state guards against a source that is wrong
about itself, as the thirty-sixth stage's order has it), then to the higher cut-off. Neither the KITTI validation drives
nor comma2k19 take part.

The forty-seventh stage (:func:`choose_biased_pitch_rate_again`; rule written 2026-12-06 before any of its candidates
ran, after the forty-sixth): the forty-second stage found a pitch rate with an offset (a MEMS gyro's: a phone's, an
ECU's) better not read, with the observer started at a zero pitch; with the anchored start and the slower observer the
question is open again. Candidates and sets as the forty-second stage's (not read, shipped; the observer with an offset
state in ``T_q`` of :data:`PITCH_OFFSET_TAUS`: none, 20, 60 s; the five general sets, +-0.3 deg/s on ``q`` as on ``p``
and +-1 deg/s on ``q`` alone), the observer as shipped since the forty-fifth stage (0.35 rad/s, anchored for 1 s) and
the unbiased filter's constants as shipped (0.05 Hz, 40 s) in the objective's part for the drives as read. The lowest
wins; ties within :data:`TIE_DEG` go to not read, then to the longer ``T_q``. Neither the KITTI validation drives nor
comma2k19 take part.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.signal import resample_poly

from .. import vehicle
from ..constants import G
from ..vehicle import conditions
from ..estimators.gated import KINEMATIC_PIF_BANK_RATE, KINEMATIC_PIF_GATE, KINEMATIC_PIF_KAPPA
from ..estimators.gyro import (GRADE_WINDOW_S, GYRO_BIAS_TAU_S, GYRO_CUTOFF_HZ, UNBIASED_GYRO, UNBIASED_PITCH,
                               KinematicGyro, KinematicGyroSmoother)
from ..estimators.kinematic_smoother import KinematicSmoother
from ..estimators.lowpass import KinematicLowPass
from ..io.kitti import load_kitti_oxts
from ..sim import SCENARIOS, run_scenario
from ..sim.params import PlantParams
from ..signals import Signals, concat_signals, sample_rate
from ..validation.kitti import KITTI_SCORING
from ..validation.scoring import SHORT_PIECES_S, masks, scored_pieces
from ..validation.splits import KITTI_TRAINING
from ..vehicle import load_vehicle
from .manoeuvres import drive_set
from .objective import drive_errors

#: the thirtieth stage's pieces (s) and candidates: the check's centred-mean windows (s) and its slope range (-)
CHECK_PIECES_S = (12.0, 20.0)
CHECK_WINDOWS_S = ((1.0, 10.0), (0.5, 4.0))
CHECK_RANGES = ((0.5, 2.0), (0.3, 3.0))
#: the thirty-second stage's fallback check's centred-mean windows (s); its pieces are the validation's short-log
#: lengths (:data:`roadbank.validation.scoring.SHORT_PIECES_S`, 8, 12 and 20 s)
SHORT_CHECK_WINDOWS_S = (0.5, 4.0)
#: the thirty-first stage's second condition: the largest magnitude of the roll rate's correlation with the yaw rate
CHECK_MAX_CORR = 0.9
#: the twenty-ninth stage's candidates: the sideslip acceleration ``kinematic-gyro`` takes out of the kinematic estimate
GYRO_SIDESLIPS = ("none", "geometry", "quasi-static")
#: the twenty-eighth stage's candidates: the frequency (Hz) of the four poles of an order-4 ``kinematic-gyro``
GYRO_ORDER4_CUTOFFS_HZ = (0.05, 0.07, 0.1, 0.15, 0.2, 0.3)
#: the twenty-seventh stage's candidates: ``kinematic-gyro``'s ``v_min`` (m/s) and ``max_gap`` (s)
GYRO_V_MINS = (1.0, 0.05)
GYRO_MAX_GAPS = (1.0, 10.0, 60.0)
#: the twenty-sixth stage's candidates: the window (s) of the pitch that corrects the roll rate (0: no correction)
GRADE_WINDOWS_S = (0.0, 0.5, 1.0, 2.0, 4.0)
#: the twenty-fourth stage's grid: ``kinematic-gyro``'s cross-over (Hz) and offset time constant (s; 0: none),
#: and the roll-rate offset (deg/s) added to the training drives
GYRO_CUTOFFS_HZ = (0.03, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3)
GYRO_BIAS_TAUS = (0.0, 10.0, 20.0, 40.0, 80.0)
GYRO_OFFSET_DEG = 0.3
#: the thirty-fourth stage's candidate holds (s) of the offset state after a log's start, the shipped first
GYRO_START_HOLDS_S = (0.0, 2.0, 5.0, 10.0)
#: the thirty-fifth stage's candidates: the span (s) of the start's Kalman filter and its priors of the roll rate's
#: offset (deg/s)
GYRO_START_SPAN_CANDIDATE_S = 20.0
GYRO_START_OFFSETS_DEG = (0.03, 0.1, 0.3, 1.0)
#: the thirty-seventh stage's candidate priors (deg/s) of the start's Kalman filter for an unbiased roll rate
UNBIASED_START_OFFSETS_DEG = (0.03, 0.1, 0.3)
#: the thirty-eighth stage's candidate pitch windows (s) and first spans (s; inf: none)
GRADE_START_WINDOWS_S = (1.0, 2.0, 4.0)
GRADE_FIRST_SPANS_S = (math.inf, 0.5, 1.0, 2.0)
#: how the stages before the thirty-eighth ran ``kinematic-gyro``: no pitch before the grade window had passed
BEFORE_38 = {"grade_first_span": math.inf}
#: the thirty-ninth stage's candidate bandwidths (rad/s) of the pitch observer and its starts ((bandwidth rad/s, span
#: s) of a faster start; None: none)
PITCH_BANDWIDTHS = (0.5, 1.0, 2.0)
PITCH_STARTS = (None, (3.0, 3.0))
#: the fortieth stage's candidate starts of the pitch observer ((bandwidth rad/s, span s); None: none)
PITCH_START_CANDIDATES = (None, (3.0, 3.0), (3.0, 6.0), (6.0, 3.0))
#: the forty-first stage's candidate bandwidths (rad/s) of the pitch observer
PITCH_BANDWIDTH_CANDIDATES = (0.25, 0.35, 0.5)
#: the forty-second stage's candidate offset time constants (s) of a pitch rate with an offset (None: no offset
#: state) and the offsets (deg/s) of its extra sets, on q alone
PITCH_OFFSET_TAUS = (None, 20.0, 60.0)
PITCH_PHONE_OFFSET_DEG = 1.0
#: the forty-third stage's candidate cut-offs (Hz) and offset time constants (s) of the unbiased roll rate's filter
UNBIASED_CUTOFFS_AGAIN_HZ = (0.03, 0.05, 0.07, 0.1)
UNBIASED_TAUS_AGAIN_S = (20.0, 40.0, 80.0)
#: the forty-fourth stage's candidate spans (s) of the pitch observer's anchored start
PITCH_ANCHOR_SPANS_S = (1.0, 2.0, 3.0)
#: the forty-fifth stage's candidate bandwidths (rad/s) of the pitch observer and cut-offs (Hz) of the unbiased roll
#: rate's filter
ANCHORED_BANDWIDTHS = (0.25, 0.35, 0.5)
ANCHORED_CUTOFFS_HZ = (0.03, 0.05, 0.07)
#: the forty-sixth stage's candidate offset time constants (s; 0: no offset state) of the unbiased roll rate's filter
ANCHORED_BIAS_TAUS_S = (0.0, 40.0, 80.0, 160.0)
#: the thirty-ninth stage's bandwidth (rad/s) of the pitch observer for an unbiased pitch rate, as the fortieth to
#: forty-fourth stages ran it (the forty-fifth chose anew)
BANDWIDTH_39 = 0.5
#: the fortieth stage's start of the pitch observer for an unbiased pitch rate, as the forty-first to forty-fourth
#: stages ran it (the forty-fourth replaced it by the anchored start)
START_40 = (3.0, 3.0)
#: the thirty-sixth stage's constants of the gyro-aided filter for a roll rate free of offset (cut-off Hz, offset time
#: constant s), as the thirty-seventh to forty-third stages ran it (the forty-third chose anew)
UNBIASED_36 = {"cutoff": 0.07, "bias_tau": 40.0}
#: candidate cut-offs (Hz) and feed-forward gains (-)
CUTOFFS_HZ = (0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.8)
KAPPAS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4)
#: objectives closer than this (deg) count as equal
TIE_DEG = 0.002
#: the rule's simulated tie-break counts medians as equal to this (deg): the size of float rounding
EQUAL_DEG = 1e-9
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
#: the shipped cars of the simulated part, and the number of training drives per car
SIM_CARS = ("suv-paper", "sedan", "compact", "van")
SIM_DRIVES = 24
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


def lowest_tied(obj: dict, order):
    """The key of ``obj`` (key -> objective, deg) whose objective is the lowest, the keys within :data:`TIE_DEG` of
    it going to the first by ``order`` (a sort key of the keys)."""
    best = min(obj.values())
    return min((k for k, v in obj.items() if v <= best + TIE_DEG), key=order)


def _pick(cands: dict) -> tuple[float, float]:
    return lowest_tied(cands, lambda fk: (fk[1], fk[0]))


def training_logs(data_dir, scoring=KITTI_SCORING, roll_rate: bool = False, pitch_rate: bool = False):
    """``(signals, reference roll rad, scored mask)`` of each KITTI training drive found under ``data_dir``
    (the mask of ``scoring``, default :data:`~roadbank.validation.kitti.KITTI_SCORING`). Without ``roll_rate`` the
    signals are the ESP channels alone (``p`` None): the stages before the twenty-fourth read none, and ran so;
    without ``pitch_rate`` they have no ``q``: the stages before the thirty-ninth read none."""
    out = []
    for name in KITTI_TRAINING:
        found = [p for p in Path(data_dir).glob(f"*/{name}") if p.is_dir()]
        if not found:
            continue
        log = load_kitti_oxts(found[0])
        s = log.signals if pitch_rate else dataclasses.replace(log.signals, q=None)
        out.append((s, log.reference_roll, masks(s.t, s.vx, scoring)[1]))
    return out if roll_rate else without_roll_rate(out)


def simulated_sets(cars=SIM_CARS, n=SIM_DRIVES):
    """``roadbank tune``'s training drives (seed 0) of each car in ``cars`` (shipped vehicle names)."""
    return [drive_set("train", n, 0, load_vehicle(car).params) for car in cars]


def objective(build, logs, sim_sets) -> float:
    """The rule's objective (deg) of the estimator that ``build(signals)`` makes for each log
    (module docstring): a fixed estimator, or one designed for each log
    (:func:`roadbank.vehicle.for_log`, as the command line builds it)."""
    errs = log_errors(build, logs)
    return (float(np.median(errs)) if errs else 0.0) + (cars_median(sim_errors(build, sim_sets)) if sim_sets else 0.0)


def sim_errors(build, sim_sets) -> list[list[float]]:
    """The bank RMS error (deg) of each simulated drive as ``roadbank tune`` scores it, per set of ``sim_sets``
    (:func:`simulated_sets`), the estimator ``build(signals)`` makes for the drive."""
    return [[float(drive_errors(build(d.signals), [d])[0][0]) for d in drives] for drives in sim_sets]


def cars_median(errs) -> float:
    """The median over the sets (the cars) of each set's median (deg) of :func:`sim_errors`."""
    return float(np.median([np.median(e) for e in errs]))


def guarded(chosen, first, mean: dict):
    """The fourteenth stage's guard: ``chosen`` where it is ``first`` or its mean drive score is lower than
    ``first``'s (``mean``: key -> mean, deg), else ``first``."""
    return chosen if chosen == first or mean[chosen] < mean[first] else first


def log_errors(build, logs) -> list[float]:
    """The raw RMS error (deg) of ``theta`` against the INS roll on each log's scored samples (``logs`` from
    :func:`training_logs`), the estimator ``build(signals)`` makes for it."""
    return [_rms_deg(build(s).run(s).theta[m], ref[m]) for s, ref, m in logs]


def _rms_deg(theta, ref) -> float:
    """RMS (deg) of ``theta - ref`` (rad)."""
    return float(np.degrees(np.sqrt(np.mean((theta - ref) ** 2))))


def fixed(est):
    """``build`` for :func:`objective` of one estimator that needs no design per log."""
    return lambda signals: est


def per_log(name: str, car_margin: float | None = None, **options):
    """``build`` for :func:`objective`: ``name`` designed for each log as the command line does
    (no car given: :func:`roadbank.vehicle.undescribed_params` of the log; ``car_margin`` (-) other than
    the shipped :data:`~roadbank.vehicle.CAR_MARGIN`: with that margin, ``inf`` the static car, as the
    stages before the eighth ran)."""
    def build(signals):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            if car_margin is not None and "params" not in options and "vehicle" not in options:
                return vehicle.for_log(name, signals, vehicle.undescribed_params(signals, car_margin), **options)
            return vehicle.for_log(name, signals, **options)
    return build


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
    ``roadbank estimate --vehicle CAR`` does); bank RMS per drive, median per car, median over the cars
    (deg). No real log of a described car is at hand, so the simulated drives alone decide; the lowest
    wins, ties within :data:`EQUAL_DEG` to the smaller ratio (fewer logs leave the low-pass). Returns
    ``(ratio, {ratio: median})``."""
    meds: dict[float, float] = {}
    for q in sorted(ratios):
        meds[q] = float(np.median([objective(per_log("kinematic-pif", vehicle=load_vehicle(car), quiet_ratio=q), [],
                                             [drives]) for car, drives in zip(cars, sim_sets)]))
    return min(meds, key=lambda q: (round(meds[q] / EQUAL_DEG), q)), meds


def choose_described_filter(sim_sets, cars=SIM_CARS, filters=DESCRIBED_FILTERS) -> tuple[str, dict]:
    """The fifteenth stage: the filter of a quiet log whose car is described (module docstring). Each candidate of
    ``filters`` (default :data:`DESCRIBED_FILTERS`, the shipped one first) builds the default for each simulated
    training drive of each car in ``cars`` (``sim_sets`` from :func:`simulated_sets`, in that order) with that
    car's own file and ``quiet_filter``; bank RMS per drive (deg). The lowest median over the cars of the per-car
    medians wins, ties within :data:`TIE_DEG` to the earlier candidate; a candidate other than the first wins only
    where the mean over every drive is lower than the first's too. Returns ``(filter, {filter: (median, mean)})``."""
    scores: dict[str, tuple[float, float]] = {}
    for f in filters:
        errs = [sim_errors(per_log("kinematic-pif", vehicle=load_vehicle(car), quiet_filter=f), [drives])[0]
                for car, drives in zip(cars, sim_sets)]
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


def upsampled_logs(logs, rate: float = UPSAMPLED_RATE_HZ, scoring=KITTI_SCORING) -> list:
    """``logs`` (:func:`training_logs`) as a logger that interpolates its channels onto a common ``rate`` (Hz) grid
    writes them: every channel and the reference roll (rad) linear in time between the samples, the grid from the
    first sample on; the scored samples recomputed on the grid with ``scoring``."""
    out = []
    for s, ref, _ in logs:
        t = s.t[0] + np.arange(int(np.floor((s.t[-1] - s.t[0]) * rate)) + 1) / rate
        up = Signals(t, *(np.interp(t, s.t, getattr(s, c)) for c in ("vx", "ay", "r", "delta_f")))
        out.append((up, np.interp(t, s.t, ref), masks(up.t, up.vx, scoring)[1]))
    return out


@contextmanager
def design_settings(**settings):
    """Within the block, the settings of :mod:`roadbank.vehicle.conditions` that the stages from the eighteenth on
    choose (``QUIET_FLOOR_RATE``, ``QUIET_FLOOR_SIGNAL``, ``NOISE_AT_SOURCE``, ``NOISE_OCTAVE``, ``NOISE_OCTAVE_TOP``:
    keyword names in lower case) as given, restored after: every command's design reads them, so a stage runs each
    candidate as it would ship. A value that is not one of the setting's choices is refused when a design reads it."""
    names = {k: k.upper() for k in settings}
    unknown = [k for k, n in names.items() if n not in _DESIGN_SETTINGS]
    if unknown:
        raise ValueError(f"not a design setting: {', '.join(unknown)} (one of {', '.join(_DESIGN_SETTINGS).lower()})")
    before = {n: getattr(conditions, n) for n in names.values()}
    for k, n in names.items():
        setattr(conditions, n, settings[k])
    try:
        yield
    finally:
        for n, v in before.items():
            setattr(conditions, n, v)


#: the module settings of :mod:`roadbank.vehicle.conditions` that :func:`design_settings` sets
_DESIGN_SETTINGS = ("QUIET_FLOOR_RATE", "QUIET_FLOOR_SIGNAL", "NOISE_AT_SOURCE", "NOISE_OCTAVE", "NOISE_OCTAVE_TOP",
                    "TRUST_FIXED_CHANNELS")
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
    build = per_log("kinematic-pif")

    def at(signals):
        with design_settings(**settings):
            return build(signals)
    return at


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
        base = s.t[0] + np.arange(int(np.floor((s.t[-1] - s.t[0]) * rate)) + 1) / rate
        t = s.t[0] + np.arange(base.size * factor) / (rate * factor)
        up = Signals(t, *(resample_poly(np.interp(base, s.t, getattr(s, c)), factor, 1)
                          for c in ("vx", "ay", "r", "delta_f")))
        out.append((up, np.interp(t, s.t, ref), masks(up.t, up.vx, scoring)[1]))
    return out


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
    if stage == 3:
        return {q: per_log("kinematic-pif", quiet_ratio=q, quiet_filter="pif-modified", **_NO_LEAD)
                for q in QUIET_RATIOS}
    if stage == 4:
        return {f: per_log("kinematic-pif", quiet_filter=f, **_NO_LEAD) for f in QUIET_FILTERS}
    if stage == 5:
        return {v: per_log("kinematic-pif", v_min=v, **_NO_LEAD) for v in V_MINS}
    if stage == 6:
        return {n: per_log("kinematic-pif", lead_samples=n, **_STATIC_CAR) for n in LEADS_SAMPLES}
    if stage == 8:
        return {m: per_log("kinematic-pif", car_margin=m, **_LINEAR) for m in CAR_MARGINS}
    if stage == 10:
        return {c: per_log("kinematic-pif", clip=c, **_DESIGN_NOISE) for c in CLIPS}
    if stage == 12:
        return {tau: per_log("kinematic-pif", noise_tau=tau, **_ONE_RATIO) for tau in NOISE_TAUS}
    if stage == 13:
        return {tau: per_log("kinematic-pif", limit_tau=tau, **_TIME_RATE) for tau in LIMIT_TAUS}
    if stage == 14:
        return {p: per_log("kinematic-pif", bank_speed_exp=p) for p in BANK_SPEED_EXPS}
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
            errs.append(_rms_deg(theta[first:first + n][m], ref[m]))
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
    return {c: per_log("kinematic-smoother", clip=c) for c in CLIPS}


def gyro_sets(logs, offset_deg: float | None = None) -> list[list]:
    """The twenty-fourth stage's real sets: ``logs`` (:func:`training_logs`) as read, and with a constant roll-rate
    offset of +``offset_deg`` and of -``offset_deg`` (deg/s; default :data:`GYRO_OFFSET_DEG`) added to ``p`` (and to
    ``q`` where the logs have one, the thirty-ninth stage's)."""
    off = math.radians(GYRO_OFFSET_DEG if offset_deg is None else offset_deg)
    return [logs] + [[(dataclasses.replace(s, p=s.p + sign * off, q=None if s.q is None else s.q + sign * off), ref, m)
                      for s, ref, m in logs] for sign in (1.0, -1.0)]


def without_roll_rate(logs) -> list:
    """``logs`` (:func:`training_logs`) with their ESP channels alone (``p`` and ``ax`` None)."""
    return [(dataclasses.replace(s, p=None, ax=None), ref, m) for s, ref, m in logs]


def gyro_objective(build, sets) -> float:
    """The twenty-fourth stage's objective (deg): the mean over ``sets`` (:func:`gyro_sets`) of the median raw RMS
    of the estimator ``build(signals)`` makes."""
    return float(np.mean([np.median(log_errors(build, logs)) for logs in sets]))


def choose_gyro(logs, cutoffs=GYRO_CUTOFFS_HZ, bias_taus=GYRO_BIAS_TAUS) -> tuple:
    """The twenty-fourth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate). Returns
    ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective}, default objective, gyro is the default)``."""
    sets = gyro_sets(logs)
    # as it ran: the roll rate not corrected for the grade, a restart after 1 s (the later stages came after)
    obj = {(fc, bt): gyro_objective(fixed(KinematicGyro(cutoff=fc, bias_tau=bt, grade_window=0.0, max_gap=1.0)), sets)
           for fc, bt in itertools.product(cutoffs, bias_taus)}
    chosen = lowest_tied(obj, lambda k: (k[1] > 0, -k[1], k[0]))
    shipped = gyro_objective(per_log("kinematic-pif"), [without_roll_rate(logs)])   # the default as it ran
    return chosen, obj, shipped, obj[chosen] < shipped


def choose_gyro_map(logs) -> tuple[float, float, bool]:
    """The twenty-fifth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate). Returns ``(kinematic-gyro-smoother's objective, the shipped map default's, the first is the default)``."""
    sets = gyro_sets(logs)
    smoother = gyro_objective(fixed(KinematicGyroSmoother(grade_window=0.0, max_gap=1.0)), sets)   # as it ran
    shipped = gyro_objective(per_log("kinematic-smoother"), [without_roll_rate(logs)])
    return smoother, shipped, smoother < shipped


def choose_grade(logs, windows=GRADE_WINDOWS_S) -> tuple[float, dict]:
    """The twenty-sixth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``). Returns ``(window s, {window: objective deg})``."""
    sets = gyro_sets(logs)
    # as it ran: a restart after 1 s
    obj = {w: gyro_objective(fixed(KinematicGyro(grade_window=w, max_gap=1.0, **BEFORE_38)), sets) for w in windows}
    return lowest_tied(obj, lambda w: (w > 0, -w)), obj


def choose_gyro_stops(logs, v_mins=GYRO_V_MINS, max_gaps=GYRO_MAX_GAPS) -> tuple[tuple[float, float], dict]:
    """The twenty-seventh stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``((v_min m/s, max_gap s), {(v_min, max_gap): objective deg})``."""
    sets = gyro_sets(logs)
    obj = {(v, gap): gyro_objective(fixed(KinematicGyro(v_min=v, max_gap=gap, **BEFORE_38)), sets)
           for v, gap in itertools.product(v_mins, max_gaps)}
    return lowest_tied(obj, lambda k: (k != (v_mins[0], max_gaps[0]), -k[0], k[1])), obj


def choose_gyro_order(logs, cutoffs=GYRO_ORDER4_CUTOFFS_HZ) -> tuple[tuple[int, float], dict]:
    """The twenty-eighth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``). Returns ``((order, cutoff Hz), {(order, cutoff): objective deg})``."""
    sets = gyro_sets(logs)
    shipped = (2, GYRO_CUTOFF_HZ)
    cands = [shipped] + [(4, fc) for fc in cutoffs]
    obj = {(o, fc): gyro_objective(fixed(KinematicGyro(order=o, cutoff=fc, **BEFORE_38)), sets) for o, fc in cands}
    return lowest_tied(obj, lambda k: (k != shipped, k[1])), obj


def choose_gyro_sideslip(logs, modes=GYRO_SIDESLIPS) -> tuple[str, dict]:
    """The twenty-ninth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``), each drive's filter built for its fitted car. Returns ``(mode, {mode: objective deg})``."""
    sets = gyro_sets(logs)
    cars = {}
    for s, _, _ in logs:             # the fitted car reads the ESP channels: the same for the three sets' drives
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            cars[id(s.ay)] = vehicle.undescribed_params(s)

    def build(mode):
        return lambda signals: KinematicGyro(cars[id(signals.ay)], sideslip=mode, **BEFORE_38)
    obj = {mode: gyro_objective(build(mode), sets) for mode in modes}
    return lowest_tied(obj, modes.index), obj


def choose_gyro_start(logs, holds=GYRO_START_HOLDS_S, lengths=SHORT_PIECES_S) -> tuple[float, dict]:
    """The thirty-fourth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``(start_hold s, {start_hold: objective deg})``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    obj = {hold: float(np.mean([lengths_objective(fixed(KinematicGyro(grade_window=GRADE_WINDOW_S, start_hold=hold,
                                                                      **BEFORE_38)), parts) for parts in cut]))
           for hold in holds}
    return lowest_tied(obj, holds.index), obj


def choose_gyro_kalman_start(logs, offsets=GYRO_START_OFFSETS_DEG, lengths=SHORT_PIECES_S) -> tuple:
    """The thirty-fifth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``(start_offset deg/s or None for no Kalman start, {start_offset or None:
    objective deg})``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    obj = {}
    for off in (None, *offsets):
        opts = {} if off is None else {"start_span": GYRO_START_SPAN_CANDIDATE_S, "start_offset": math.radians(off)}
        build = fixed(KinematicGyro(grade_window=GRADE_WINDOW_S, **opts, **BEFORE_38))
        obj[off] = float(np.mean([lengths_objective(build, parts) for parts in cut]))
    return lowest_tied(obj, list(obj).index), obj


def choose_unbiased_gyro(logs, cutoffs=GYRO_CUTOFFS_HZ, bias_taus=GYRO_BIAS_TAUS, lengths=SHORT_PIECES_S) -> tuple:
    """The thirty-sixth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective deg})``."""
    parts = whole_and_pieces(logs, lengths)
    obj = {(fc, bt): lengths_objective(fixed(KinematicGyro(cutoff=fc, bias_tau=bt, grade_window=GRADE_WINDOW_S,
                                                           **BEFORE_38)), parts)
           for fc in cutoffs for bt in bias_taus}
    shipped = (GYRO_CUTOFF_HZ, GYRO_BIAS_TAU_S)
    return lowest_tied(obj, lambda key: (key != shipped, -key[1], -key[0])), obj


def choose_unbiased_start(logs, offsets=UNBIASED_START_OFFSETS_DEG, lengths=SHORT_PIECES_S) -> tuple:
    """The thirty-seventh stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``(start_offset deg/s or None for no Kalman start, {start_offset or None:
    objective deg})``."""
    parts = whole_and_pieces(logs, lengths)
    base = dict(**UNBIASED_36, grade_window=GRADE_WINDOW_S)
    obj = {}
    for off in (None, *offsets):
        opts = {} if off is None else {"start_span": 2.0 * UNBIASED_36["bias_tau"], "start_offset": math.radians(off)}
        obj[off] = lengths_objective(fixed(KinematicGyro(**base, **opts, **BEFORE_38)), parts)
    return lowest_tied(obj, list(obj).index), obj


def choose_grade_start(logs, windows=GRADE_START_WINDOWS_S, spans=GRADE_FIRST_SPANS_S, lengths=SHORT_PIECES_S):
    """The thirty-eighth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate and ``ax``). Returns ``((grade_window s, grade_first_span s), {(window, span): objective deg})``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    unbiased = UNBIASED_36
    obj = {}
    for w in windows:
        for first in (f for f in spans if f < w or f == math.inf):      # none, and every first span below W
            grade = dict(grade_window=w, grade_first_span=first)
            general = np.mean([lengths_objective(fixed(KinematicGyro(**grade)), parts) for parts in cut])
            free = lengths_objective(fixed(KinematicGyro(**unbiased, **grade)), cut[0])    # the drives as read
            obj[(w, first)] = float(0.5 * (general + free))
    return lowest_tied(obj, lambda key: (key != (GRADE_WINDOW_S, math.inf), -key[0], -key[1])), obj


def choose_pitch_rate(logs, bandwidths=PITCH_BANDWIDTHS, starts=PITCH_STARTS, lengths=SHORT_PIECES_S):
    """The thirty-ninth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their
    roll rate, ``ax`` and pitch rate). Returns ``(key, {key: objective deg})``, a key ``("window",)`` (the shipped
    pitch) or ``(use, bandwidth rad/s, start)`` with ``use`` ``"unbiased"`` or ``"always"``."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    shipped = sets_objective(cut, pitch_bandwidth=0.0)
    obj = {("window",): 0.5 * (shipped + sets_objective(cut[:1], **UNBIASED_36, pitch_bandwidth=0.0))}
    for w, start in itertools.product(bandwidths, starts):
        pitch = dict(pitch_bandwidth=w, pitch_start=start)
        free = sets_objective(cut[:1], **UNBIASED_36, **pitch)                      # the drives as read
        obj[("unbiased", w, start)] = 0.5 * (shipped + free)
        obj[("always", w, start)] = 0.5 * (sets_objective(cut, **pitch) + free)
    return lowest_tied(obj, lambda k: (k != ("window",), k[0] != "unbiased", k[2] is not None, k[1])), obj


def unbiased_pitch_objectives(logs, candidates: dict, lengths=SHORT_PIECES_S, unbiased=None) -> dict:
    """``{key: objective deg}`` of the fortieth and forty-first stages: for each of ``candidates`` (key -> the
    ``KinematicGyro`` pitch options of the observer for an unbiased pitch rate), the thirty-ninth stage's objective:
    the mean of the window's objective on the thirty-fourth stage's sets (a pitch rate with an offset is not read) and
    the unbiased filter's with those options on the training ``logs`` as read, each whole and in pieces (its cut-off
    and offset time constant ``unbiased``, default :data:`UNBIASED_36`, as those stages ran)."""
    cut = [whole_and_pieces(one, lengths) for one in gyro_sets(logs)]
    shipped = sets_objective(cut, pitch_bandwidth=0.0)
    unbiased = UNBIASED_36 if unbiased is None else unbiased
    return {key: 0.5 * (shipped + sets_objective(cut[:1], **unbiased, **pitch))
            for key, pitch in candidates.items()}


def choose_pitch_start(logs, starts=PITCH_START_CANDIDATES, lengths=SHORT_PIECES_S):
    """The fortieth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(start, {start: objective deg})``, a start ``(bandwidth rad/s, span s)`` or
    None."""
    obj = unbiased_pitch_objectives(logs, {st: dict(pitch_bandwidth=0.5, pitch_start=st) for st in starts}, lengths)
    return lowest_tied(obj, lambda st: (st is None, () if st is None else (st[1], st[0]))), obj


def choose_pitch_bandwidth(logs, bandwidths=PITCH_BANDWIDTH_CANDIDATES, lengths=SHORT_PIECES_S):
    """The forty-first stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(bandwidth rad/s, {bandwidth: objective deg})``."""
    obj = unbiased_pitch_objectives(
        logs, {w: dict(pitch_bandwidth=w, pitch_start=START_40) for w in bandwidths}, lengths)
    return lowest_tied(obj, lambda w: (w != 0.5, -w)), obj


def choose_pitch_anchor(logs, spans=PITCH_ANCHOR_SPANS_S, lengths=SHORT_PIECES_S):
    """The forty-fourth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(key, {key: objective deg})``, a key ``(anchor span s or None, start)``
    of the observer (``start`` as ``pitch_start``)."""
    keys = [(None, START_40)] + [(a, None) for a in spans] + [(spans[0], START_40)]
    obj = unbiased_pitch_objectives(
        logs, {k: dict(pitch_bandwidth=BANDWIDTH_39, pitch_anchor=k[0], pitch_start=k[1]) for k in keys},
        lengths, UNBIASED_GYRO)
    return lowest_tied(obj, lambda k: (k[0] is not None, k[0] or 0.0, k[1] is not None)), obj


def choose_biased_pitch_rate(logs, taus=PITCH_OFFSET_TAUS, lengths=SHORT_PIECES_S, observer=None, unbiased=None):
    """The forty-second stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``(key, {key: objective deg})``, a key ``"none"`` (a pitch rate with an
    offset not read) or ``T_q`` (s; None: the observer without an offset state). ``observer`` (``KinematicGyro``'s
    pitch options) and ``unbiased`` (its cut-off and offset time constant for the drives as read): as that stage ran
    (default), or the forty-seventh's (:func:`choose_biased_pitch_rate_again`)."""
    phone = math.radians(PITCH_PHONE_OFFSET_DEG)
    sets = gyro_sets(logs) + [[(dataclasses.replace(s, q=s.q + sign * phone), ref, m) for s, ref, m in logs]
                              for sign in (1.0, -1.0)]
    cut = [whole_and_pieces(one, lengths) for one in sets]
    observer = dict(pitch_bandwidth=BANDWIDTH_39, pitch_start=START_40) if observer is None else observer
    free = sets_objective(cut[:1], **(UNBIASED_36 if unbiased is None else unbiased), **observer)
    obj = {"none": 0.5 * (sets_objective(cut, pitch_bandwidth=0.0) + free)}
    for tq in taus:
        obj[tq] = 0.5 * (sets_objective(cut, **observer, pitch_offset_tau=tq) + free)
    return lowest_tied(obj, lambda k: (k != "none", -(k or 0.0) if k != "none" else 0.0)), obj


def choose_biased_pitch_rate_again(logs, taus=PITCH_OFFSET_TAUS, lengths=SHORT_PIECES_S):
    """The forty-seventh stage (module docstring): :func:`choose_biased_pitch_rate` with the observer and the unbiased
    filter's constants as shipped."""
    return choose_biased_pitch_rate(logs, taus, lengths, UNBIASED_PITCH, UNBIASED_GYRO)


def choose_unbiased_gyro_again(logs, cutoffs=UNBIASED_CUTOFFS_AGAIN_HZ, taus=UNBIASED_TAUS_AGAIN_S,
                               lengths=SHORT_PIECES_S):
    """The forty-third stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective deg})``."""
    cut = [whole_and_pieces(logs, lengths)]
    observer = dict(pitch_bandwidth=BANDWIDTH_39, pitch_start=START_40)
    obj = {(fc, bt): sets_objective(cut, cutoff=fc, bias_tau=bt, **observer) for fc in cutoffs for bt in taus}
    shipped = (UNBIASED_36["cutoff"], UNBIASED_36["bias_tau"])
    return lowest_tied(obj, lambda k: (k != shipped, -k[1], -k[0])), obj


def choose_unbiased_after_anchor(logs, bandwidths=ANCHORED_BANDWIDTHS, cutoffs=ANCHORED_CUTOFFS_HZ,
                                 lengths=SHORT_PIECES_S):
    """The forty-fifth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``((bandwidth rad/s, cutoff Hz), {(bandwidth, cutoff): objective deg})``."""
    cut = [whole_and_pieces(logs, lengths)]
    obj = {(w, fc): sets_objective(cut, **{**UNBIASED_GYRO, **UNBIASED_PITCH, "cutoff": fc, "pitch_bandwidth": w})
           for w in bandwidths for fc in cutoffs}
    shipped = (0.5, 0.05)
    return lowest_tied(obj, lambda k: (k != shipped, -k[0], -k[1])), obj


def choose_unbiased_offset_again(logs, taus=ANCHORED_BIAS_TAUS_S, cutoffs=ANCHORED_CUTOFFS_HZ,
                                 lengths=SHORT_PIECES_S):
    """The forty-sixth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate, ``ax`` and pitch rate). Returns ``((cutoff Hz, bias_tau s), {(cutoff, bias_tau): objective deg})``."""
    cut = [whole_and_pieces(logs, lengths)]
    obj = {(fc, bt): sets_objective(cut, cutoff=fc, bias_tau=bt, **UNBIASED_PITCH) for fc in cutoffs for bt in taus}
    shipped = (0.05, 40.0)
    return lowest_tied(obj, lambda k: (k != shipped, -k[1], -k[0])), obj


def sets_objective(cut, **options) -> float:
    """The mean over ``cut`` (sets, each cut by :func:`whole_and_pieces`) of :func:`lengths_objective` of
    ``KinematicGyro(**options)`` (deg): the thirty-ninth to forty-second stages' parts."""
    return float(np.mean([lengths_objective(fixed(KinematicGyro(**options)), parts) for parts in cut]))


def whole_and_pieces(logs, lengths=SHORT_PIECES_S) -> list:
    """``[logs, pieces...]``: ``logs`` (:func:`training_logs`) whole, then cut into each of ``lengths`` (s) by
    :func:`check_pieces`, each piece ``(signals, reference roll rad, scored mask)``: the parts of
    :func:`lengths_objective`."""
    return [logs] + [[(p, ref, m) for p, ref, m, _ in check_pieces(logs, n)] for n in lengths]


def lengths_objective(build, parts) -> float:
    """The mean over ``parts`` (:func:`whole_and_pieces`) of the median raw RMS (deg) of the estimator
    ``build(signals)`` makes: the objective of the thirty-fourth to thirty-eighth stages, per set."""
    return float(np.mean([np.median(log_errors(build, part)) for part in parts]))


def check_pieces(logs, length: float) -> list:
    """``logs`` (:func:`training_logs`) cut into consecutive whole pieces of ``length`` (s), each ``(signals, reference
    roll rad, scored mask, (drive index, first sample, end sample))`` with the KITTI scoring within the piece; pieces
    with no scored sample left out."""
    return [(piece, ref[a:b], m, (i, a, b)) for i, (s, ref, _) in enumerate(logs)
            for a, b, piece, m in scored_pieces(s, length, KITTI_SCORING)]


def _piece_checks(piece, windows, pitch_rate=None) -> list:
    """``(slope, |correlation with the yaw rate|)`` of the roll-rate check on ``piece`` with ``windows``, for the roll
    rate as read, then negated, the yaw rate in its place, deg/s read as rad/s, and (given ``pitch_rate``, rad/s, the
    piece's) the pitch rate in its place; slopes to two digits, as :func:`roadbank.vehicle.log_conditions` gives
    them."""
    n = conditions.design_span(piece)
    span, vx, moving = conditions._design_part(piece, 5.0)
    variants = [span.p, -span.p, span.r, np.degrees(span.p)]
    if pitch_rate is not None:
        variants.append(np.asarray(pitch_rate)[:n])
    return [(conditions._two_digits(conditions.roll_rate_slope(dataclasses.replace(span, p=p), vx, moving, windows)),
             conditions.yaw_correlation(dataclasses.replace(span, p=p), moving)) for p in variants]


def _default_errors(piece, ref, m, cond: dict, variants) -> list[float]:
    """The raw RMS (deg) on ``piece``'s scored samples ``m`` against ``ref`` (rad) of the default as the command line
    builds it for the piece's fitted car (fitted at its conditions ``cond``), once for each of ``variants`` (the
    conditions as each candidate reads them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        car = vehicle.undescribed_params(piece, cond=cond)
        ests = [vehicle.for_conditions("kinematic-pif", v, car) for v in variants]
    return [_rms_deg(est.run(piece).theta[m], ref[m]) for est in ests]


def _check_rows(logs, lengths, windows, pitch_rates=None) -> list:
    """Per piece of each length (:func:`check_pieces`): ``(length, error of the default with the roll rate accepted,
    error without, {windows: _piece_checks})`` (deg); ``pitch_rates``: each drive's pitch rate (rad/s), or None."""
    rows = []
    for length in lengths:
        for piece, ref, m, (i, a, b) in check_pieces(logs, length):
            with design_settings(trust_fixed_channels=False):       # as the thirtieth and thirty-first ran
                cond = vehicle.log_conditions(piece)
            errs = _default_errors(piece, ref, m, cond,
                                   [{**cond, "log_roll_rate": 1.0}, conditions.esp_conditions(cond)])
            q = None if pitch_rates is None else pitch_rates[i][a:b]
            rows.append((length, *errs, {w: _piece_checks(piece, w, q) for w in windows}))
    return rows


def _check_choice(rows, lengths, cands: dict, order) -> tuple:
    """The thirtieth and thirty-first stages' choice over ``cands`` (key -> ``(windows, accept(slope, corr))``) on
    ``rows`` (:func:`_check_rows`): ``(chosen key, {key: objective deg}, {key: wrong channels accepted})``; ties
    within :data:`TIE_DEG` by ``order`` (a sort key of the keys, the shipped check first), none allowed: the first
    of ``order``."""
    obj, wrong = {}, {}
    for key, (w, accept) in cands.items():
        wrong[key] = sum(accept(*x) for *_, checks in rows for x in checks[w][1:])
        obj[key] = float(np.mean([np.median([eg if accept(*checks[w][0]) else ee
                                             for n, eg, ee, checks in rows if n == length]) for length in lengths]))
    allowed = {k: v for k, v in obj.items() if wrong[k] == 0}
    if not allowed:                              # none meets the constraint: the shipped check stays
        return min(cands, key=order), obj, wrong
    return lowest_tied(allowed, order), obj, wrong


def _slope_within(lo: float, hi: float, max_corr: float = math.inf):
    """``accept(slope, corr)``: the slope within ``[lo, hi]`` and the correlation with the yaw rate below
    ``max_corr`` (a NaN correlation passes: it tells nothing)."""
    return lambda slope, corr: slope is not None and lo <= slope <= hi and not corr >= max_corr


def choose_roll_check(logs, lengths=CHECK_PIECES_S, windows=CHECK_WINDOWS_S, ranges=CHECK_RANGES) -> tuple:
    """The thirtieth stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``). Returns ``((windows, range), {(windows, range): objective deg}, {(windows, range): pieces on
    which a wrong channel was accepted})``; where every candidate accepts one, the shipped check."""
    cands = {(w, b): (w, _slope_within(b[0], b[1])) for w, b in itertools.product(windows, ranges)}
    shipped = (windows[0], ranges[0])
    return _check_choice(_check_rows(logs, lengths, windows), lengths, cands,
                         lambda k: (k != shipped, -k[0][1], k[1][1] - k[1][0]))


def training_pitch_rates(data_dir) -> list:
    """The INS's pitch rate (rad/s) of each KITTI training drive under ``data_dir``, in :func:`training_logs`' order."""
    return [load_kitti_oxts(found[0]).signals.q for name in KITTI_TRAINING
            if (found := [p for p in Path(data_dir).glob(f"*/{name}") if p.is_dir()])]


def choose_roll_check_again(logs, pitch_rates, lengths=CHECK_PIECES_S, windows=CHECK_WINDOWS_S,
                            ranges=CHECK_RANGES) -> tuple:
    """The thirty-first stage (module docstring) on the KITTI training ``logs`` (:func:`training_logs` with their roll
    rate and ``ax``) and their ``pitch_rates`` (:func:`training_pitch_rates`). Returns ``((windows, range, with the
    yaw-rate condition), {key: objective deg}, {key: wrong channels accepted})``."""
    cands = {(w, b, c): (w, _slope_within(b[0], b[1], CHECK_MAX_CORR if c else math.inf))
             for w, b, c in itertools.product(windows, ranges, (False, True))}
    shipped = (windows[0], ranges[0], False)
    return _check_choice(_check_rows(logs, lengths, windows, pitch_rates), lengths, cands,
                         lambda k: (k != shipped, -k[0][1], k[1][1] - k[1][0], k[2]))


def _short_piece(piece, ref, m, pitch_rate) -> tuple:
    """One piece of the thirty-second stage: ``(errors, checks)``; ``errors`` the raw RMS (deg) of the default built for
    the piece's fitted car with the roll rate and ``ax`` accepted, with the roll rate alone and with neither (the ESP
    default); ``checks[windows]`` the ``(roll, ax)`` readings with the two check windows: ``roll`` as
    :func:`_piece_checks` gives them (with the pitch rate last), ``ax`` the :func:`roadbank.vehicle.conditions.ax_slope`
    of the ``ax`` as read, negated, in g read as m/s^2 and ``ay`` in its place (two digits)."""
    cond = vehicle.log_conditions(piece)
    errors = _default_errors(piece, ref, m, cond, [{**cond, "log_roll_rate": 1.0, "log_ax": ax} for ax in (1.0, None)]
                             + [conditions.esp_conditions(cond)])
    span, vx, moving = conditions._design_part(piece, 5.0)
    axes = (span.ax, -span.ax, span.ax / G, span.ay)
    checks = {w: (_piece_checks(piece, w, pitch_rate),
                  [conditions._two_digits(conditions._slope_on_integral(span.t, vx, a, moving, w)) for a in axes])
              for w in (conditions.ROLL_CHECK_WINDOWS_S, SHORT_CHECK_WINDOWS_S)}
    return errors, checks


def short_rows(logs, pitch_rates, lengths=SHORT_PIECES_S) -> list:
    """The thirty-second stage's rows: ``(length s, errors, checks)`` (:func:`_short_piece`) per piece of each length
    (:func:`check_pieces`) of the KITTI training ``logs`` with their roll rate and ``ax``, ``pitch_rates`` each
    drive's pitch rate (rad/s, :func:`training_pitch_rates`)."""
    return [(length, *_short_piece(piece, ref, m, pitch_rates[i][a:b]))
            for length in lengths for piece, ref, m, (i, a, b) in check_pieces(logs, length)]


def _short_readings(checks, fallback) -> tuple[list, list]:
    """The roll-rate and ``ax`` readings ``([(slope, corr, range)...], [(slope, range)...])`` of a candidate on one
    piece's ``checks`` (:func:`_short_piece`): the shipped windows' where they give a slope, else (``fallback``, a
    slope range, or None: no fallback) the short windows' with that range; a fallback roll rate that correlates with
    the yaw rate by :data:`CHECK_MAX_CORR` or more gives no slope."""
    rolls, axes = checks[conditions.ROLL_CHECK_WINDOWS_S]
    short_rolls, short_axes = checks[SHORT_CHECK_WINDOWS_S]
    shipped = conditions.ROLL_SLOPE_RANGE
    roll = [(x, c, shipped) if x is not None or fallback is None
            else ((y if not d >= CHECK_MAX_CORR else None), d, fallback)
            for (x, c), (y, d) in zip(rolls, short_rolls)]
    ax = [(x, shipped) if x is not None or fallback is None else (y, fallback) for x, y in zip(axes, short_axes)]
    return roll, ax


def _within(slope, span) -> bool:
    return slope is not None and span[0] <= slope <= span[1]


def choose_short_check(rows, lengths=SHORT_PIECES_S, ranges=CHECK_RANGES) -> tuple:
    """The thirty-second stage (module docstring) on its ``rows`` (:func:`short_rows`). Returns ``(chosen, {candidate:
    objective deg}, {candidate: wrong roll-rate or ax channels accepted}, {candidate: pitch rates accepted})``; a
    candidate is None (the shipped check alone) or the fallback's slope range; where every candidate accepts a wrong
    channel, the shipped check."""
    obj, wrong, pitch = {}, {}, {}
    for cand in (None, *ranges):
        per_length: dict[float, list[float]] = {n: [] for n in lengths}
        wrong[cand], pitch[cand] = 0, 0
        for n, errors, checks in rows:
            roll, ax = _short_readings(checks, cand)
            use = [_within(x, b) for x, _, b in roll]
            use_ax = [_within(x, b) for x, b in ax]
            per_length[n].append(errors[0] if use[0] and use_ax[0] else errors[1] if use[0] else errors[2])
            wrong[cand] += sum(use[1:4]) + sum(use_ax[1:])
            pitch[cand] += sum(use[4:])
        obj[cand] = float(np.mean([np.median(v) for v in per_length.values()]))
    order = [None, *sorted(ranges, key=lambda b: b[1] - b[0])]
    allowed = {k: v for k, v in obj.items() if wrong[k] == 0}
    chosen = lowest_tied(allowed, order.index) if allowed else None
    return chosen, obj, wrong, pitch


#: the thirty-third stage's candidates for a format's fixed channel, the shipped first
FIXED_CHANNEL_RULES = ("judged", "undecided", "always")


def choose_fixed_channels(rows, rules=FIXED_CHANNEL_RULES) -> tuple[str, dict]:
    """The thirty-third stage (module docstring) on the thirty-second's ``rows`` (:func:`short_rows`): ``(chosen rule,
    {rule: objective deg})``. A piece's channel is used by ``"judged"`` where the shipped check's slope is within
    :data:`roadbank.vehicle.conditions.ROLL_SLOPE_RANGE`, by ``"undecided"`` also where it gives none (every
    training channel moves: no slope means too few samples), by ``"always"`` everywhere."""
    def used(slope, rule):
        return (rule == "always" or (slope is None and rule == "undecided")
                or _within(slope, conditions.ROLL_SLOPE_RANGE))

    obj = {}
    for rule in rules:
        per_length: dict = {}
        for n, errors, checks in rows:
            rolls, axes = checks[conditions.ROLL_CHECK_WINDOWS_S]
            roll, ax = used(rolls[0][0], rule), used(axes[0], rule)
            per_length.setdefault(n, []).append(errors[0] if roll and ax else errors[1] if roll else errors[2])
        obj[rule] = float(np.mean([np.median(v) for v in per_length.values()]))
    return lowest_tied(obj, rules.index), obj


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
        errs.append(_rms_deg(build(s).run(s).theta[m], res.truth.theta[m]))
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
