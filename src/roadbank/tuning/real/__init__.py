r"""Choices made on training data, stage by stage; the first: the cut-off and feed-forward gain of ``kinematic-lp`` /
``kinematic-ff``.

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

The stages, one module per topic, each module's docstring holding its stages' rules:

* :mod:`.esp` — the first to twenty-third stages: the default on the ESP channels;
* :mod:`.gyro` — the roll-rate filter ``kinematic-gyro``;
* :mod:`.grade` — the grade and the pitch that correct the roll rate;
* :mod:`.checks` — the check that a log's roll rate is one;
* :mod:`.roads` — the fifty-eighth to sixty-third stages: a design decided again as a log's roads change, a quiet log
  of a car nobody described;
* :mod:`.offline` — the sixty-fourth, sixty-fifth and sixty-seventh stages: the map's low-pass smoother gated to the
  model smoother, from a lowest speed, held open for a time;
* :mod:`.blend_gate` — the sixty-sixth stage: the causal blend's gate at every speed;
* :mod:`.rear_trim` — the sixty-eighth stage: a described car's rear cornering stiffness trimmed to the log;
* :mod:`.common` — what every stage shares: the training drives, the simulated sets, the objective, ties, pieces.

Every name of the stages is importable from here.
"""

from __future__ import annotations

from .common import (BANDWIDTH_39, BEFORE_38, BEFORE_64, BEFORE_65, BEFORE_67, BEFORE_69, design_settings, within,
                     EQUAL_DEG, SIM_CARS, SIM_DRIVES, START_40, TIE_DEG,
                     UNBIASED_36, cars_median, check_pieces, fixed, guarded, lengths_objective, log_errors, lowest_tied,
                     objective,
                     per_log, rms_deg, sim_errors, simulated_sets, training_logs, whole_and_pieces, without_roll_rate)
from .esp import (BANK_RATES_DEG, BANK_SPEED_EXPS, CAR_MARGINS, CLIPS, CUTOFFS_HZ, DESCRIBED_FILTERS, GATE_GRID,
                  GATE_TFS, GATE_TF_RATES, KAPPAS, LEADS_SAMPLES, LIMIT_TAUS, LONG_GAP_S, LOUD_AY_NOISE, LOUD_DOF,
                  LOUD_RATE_HZ, LOUD_SEED, LowpassChoice, NOISE_AT_SOURCE_CHOICES, NOISE_OCTAVES, NOISE_OCTAVE_TOPS,
                  NOISE_TAUS, NO_GATE, PAPER_SEEDS, QUIET_FILTERS, QUIET_FLOOR_RATES, QUIET_FLOOR_READINGS,
                  QUIET_MEASURES, QUIET_RATIOS, RESAMPLE_FACTOR, UPSAMPLED_RATE_HZ, V_MINS, choose_by_roads,
                  choose_described_filter, choose_described_ratio, choose_gate_at_source, choose_gate_filter,
                  choose_read_at_source, choose_quiet_gyro, gyro_sim_sets, QUIET_GYRO_OFFSETS,
                  choose_source_rounding, quiet_noise_sets, rounded_logs, ROUNDINGS, SOURCE_ROUNDING_SIM_NOISE,
                  choose_loud_gate, choose_lowpass,
                  choose_noise_at_source, choose_noise_octave, choose_noise_tau, choose_octave_top, choose_prior_again,
                  choose_quiet_floor_rate, choose_quiet_floor_signal, choose_quiet_measure, choose_smoother,
                  gate_filter_sets, kinematic_pif_candidates, long_errors, long_logs, long_median,
                  loud_gate_candidates, loud_sets, paper_median, paper_sets, prior_candidates, resampled_logs,
                  smoother_clip_candidates, upsampled_logs, held_logs, HELD_RATES_HZ)
from .gyro import (ANCHORED_BIAS_TAUS_S, ANCHORED_CUTOFFS_HZ, GAP_LENGTHS_S, GAP_PLACES, GYRO_BIAS_TAUS,
                   GYRO_CUTOFFS_HZ, GYRO_MAX_GAPS,
                   GYRO_OFFSET_DEG, GYRO_ORDER4_CUTOFFS_HZ, GYRO_SIDESLIPS, GYRO_START_HOLDS_S, GYRO_START_OFFSETS_DEG,
                   GYRO_START_SPAN_CANDIDATE_S, GYRO_V_MINS, UNBIASED_CUTOFFS_AGAIN_HZ, UNBIASED_START_OFFSETS_DEG,
                   UNBIASED_TAUS_AGAIN_S, choose_gyro, choose_gyro_kalman_start, choose_gyro_map, choose_gyro_order,
                   choose_gyro_sideslip, choose_gyro_start, choose_gyro_stops, choose_log_gaps, choose_smoother_passes,
                   choose_smoother_settled, choose_unbiased_gyro, choose_unbiased_gyro_again,
                   choose_unbiased_offset_again, choose_unbiased_start, gap_sets, gyro_objective, gyro_sets,
                   sets_objective, with_gaps)
from .grade import (ANCHORED_BANDWIDTHS, GRADE_FIRST_SPANS_S, GRADE_START_WINDOWS_S, GRADE_WINDOWS_S,
                    PITCH_ANCHOR_SPANS_S, PITCH_BANDWIDTHS, PITCH_BANDWIDTH_CANDIDATES, PITCH_OFFSET_TAUS,
                    PITCH_PHONE_OFFSET_DEG, PITCH_STARTS, PITCH_START_CANDIDATES, choose_biased_pitch_rate,
                    choose_biased_pitch_rate_again, choose_grade, choose_grade_start, choose_pitch_anchor,
                    choose_pitch_bandwidth, choose_pitch_rate, choose_pitch_start, choose_unbiased_after_anchor,
                    training_pitch_rates, unbiased_pitch_objectives)
from .checks import (CHECK_MAX_CORR, CHECK_PIECES_S, CHECK_RANGES, CHECK_WINDOWS_S, FIXED_CHANNEL_RULES,
                     SHORT_CHECK_WINDOWS_S, choose_fixed_channels, choose_roll_check, choose_roll_check_again,
                     choose_short_check, short_rows)
from .roads import (STEEP_ROAD_ORDER, STEEP_ROAD_CUTOFF_HZ, UNDESCRIBED_GAIN_DEG, choose_undescribed_quiet,
                    BACK_LOUD_AY, ROAD_CHANGE_BACK_GAIN_DEG, ROAD_CHANGE_BACK_LOSS_DEG, ROAD_CHANGE_BACK_WORSE_DEG,
                    choose_road_change_back, loud_and_quiet_logs, loud_then_quiet_sets,
                    QUIET_INS_GAIN_DEG, choose_quiet_ins, smooth_road_logs, RESTART_GAP_S, ROAD_CHANGE_GAIN_DEG,
                    ROAD_CHANGE_GYRO_GAIN_DEG, ROAD_CHANGE_LOSS_DEG,
                    choose_road_change, choose_road_change_gyro, long_quiet_sets, long_sim_errors, road_change_build,
                    smooth_start_logs)
from .blend_gate import (BLEND_GATE_SIM_LOSS_DEG, BLEND_GATE_SPEEDS, BLEND_GATE_TAIL_LOSS,
                         choose_blend_gate_speed)
from .rear_trim import (REAR_TRIM_LOSS_DEG, REAR_TRIM_REAL_CAR, REAR_TRIM_REAL_LOSS_DEG, REAR_TRIM_RUNS,
                        REAR_TRIM_SEEDS, REAR_TRIM_SIM_TAIL_LOSS, REAR_TRIM_TAIL_GAIN, campaign_errors,
                        choose_rear_trim)
from .offline import (GATE_GAIN_DEG, GATE_REAL_LOSS_DEG, GATE_SPEEDS, GATE_SPEED_SIM_LOSS_DEG, GATE_SPEED_TAIL_LOSS,
                      GATE_TAIL_GAIN, SHAKEN_SEED, choose_gate_speed, choose_smoother_gate, lowest_eligible,
                      GATE_HOLDS_S, choose_gate_hold,
                      shaken_sets, stage_sets)

__all__ = ["REAR_TRIM_LOSS_DEG", "REAR_TRIM_REAL_CAR", "REAR_TRIM_REAL_LOSS_DEG", "REAR_TRIM_RUNS", "REAR_TRIM_SEEDS",
           "REAR_TRIM_SIM_TAIL_LOSS", "REAR_TRIM_TAIL_GAIN", "campaign_errors", "choose_rear_trim",
           "GATE_GAIN_DEG", "GATE_REAL_LOSS_DEG", "GATE_TAIL_GAIN", "SHAKEN_SEED", "choose_smoother_gate",
           "shaken_sets",
           "BEFORE_64", "BEFORE_65", "within", "GATE_SPEEDS", "GATE_SPEED_SIM_LOSS_DEG", "GATE_SPEED_TAIL_LOSS",
           "choose_gate_speed", "stage_sets", "lowest_eligible", "GATE_HOLDS_S", "choose_gate_hold", "BEFORE_67",
           "BEFORE_69",
           "BLEND_GATE_SIM_LOSS_DEG",
           "BLEND_GATE_SPEEDS", "BLEND_GATE_TAIL_LOSS", "choose_blend_gate_speed", "STEEP_ROAD_ORDER",
           "STEEP_ROAD_CUTOFF_HZ", "UNDESCRIBED_GAIN_DEG", "choose_undescribed_quiet",
           "BACK_LOUD_AY", "ROAD_CHANGE_BACK_GAIN_DEG", "ROAD_CHANGE_BACK_LOSS_DEG", "ROAD_CHANGE_BACK_WORSE_DEG",
           "choose_road_change_back", "loud_and_quiet_logs", "loud_then_quiet_sets",
           "QUIET_INS_GAIN_DEG", "choose_quiet_ins", "smooth_road_logs",
           "RESTART_GAP_S", "ROAD_CHANGE_GYRO_GAIN_DEG", "choose_road_change_gyro",
           "ROAD_CHANGE_GAIN_DEG", "ROAD_CHANGE_LOSS_DEG", "choose_road_change", "long_quiet_sets",
           "long_sim_errors", "road_change_build", "smooth_start_logs",
           "ANCHORED_BANDWIDTHS", "ANCHORED_BIAS_TAUS_S", "ANCHORED_CUTOFFS_HZ", "BANDWIDTH_39", "BANK_RATES_DEG",
           "BANK_SPEED_EXPS", "BEFORE_38", "CAR_MARGINS", "CHECK_MAX_CORR", "CHECK_PIECES_S", "CHECK_RANGES",
           "CHECK_WINDOWS_S", "CLIPS", "CUTOFFS_HZ", "DESCRIBED_FILTERS", "EQUAL_DEG", "FIXED_CHANNEL_RULES",
           "GAP_LENGTHS_S", "GAP_PLACES",
           "GATE_GRID", "GATE_TFS", "GATE_TF_RATES", "GRADE_FIRST_SPANS_S", "GRADE_START_WINDOWS_S", "GRADE_WINDOWS_S",
           "GYRO_BIAS_TAUS", "GYRO_CUTOFFS_HZ", "GYRO_MAX_GAPS", "GYRO_OFFSET_DEG", "GYRO_ORDER4_CUTOFFS_HZ",
           "GYRO_SIDESLIPS", "GYRO_START_HOLDS_S", "GYRO_START_OFFSETS_DEG", "GYRO_START_SPAN_CANDIDATE_S",
           "GYRO_V_MINS", "KAPPAS", "LEADS_SAMPLES", "LIMIT_TAUS", "LONG_GAP_S", "LOUD_AY_NOISE", "LOUD_DOF",
           "LOUD_RATE_HZ", "LOUD_SEED", "LowpassChoice", "NOISE_AT_SOURCE_CHOICES", "NOISE_OCTAVES",
           "NOISE_OCTAVE_TOPS", "NOISE_TAUS", "NO_GATE", "PAPER_SEEDS", "PITCH_ANCHOR_SPANS_S", "PITCH_BANDWIDTHS",
           "PITCH_BANDWIDTH_CANDIDATES", "PITCH_OFFSET_TAUS", "PITCH_PHONE_OFFSET_DEG", "PITCH_STARTS",
           "PITCH_START_CANDIDATES", "QUIET_FILTERS", "QUIET_FLOOR_RATES", "QUIET_FLOOR_READINGS", "QUIET_MEASURES",
           "QUIET_RATIOS", "RESAMPLE_FACTOR", "SHORT_CHECK_WINDOWS_S", "SIM_CARS", "SIM_DRIVES", "START_40", "TIE_DEG",
           "UNBIASED_36", "UNBIASED_CUTOFFS_AGAIN_HZ", "UNBIASED_START_OFFSETS_DEG", "UNBIASED_TAUS_AGAIN_S",
           "UPSAMPLED_RATE_HZ", "V_MINS", "cars_median", "check_pieces", "choose_biased_pitch_rate",
           "choose_biased_pitch_rate_again", "choose_by_roads", "choose_described_filter", "choose_described_ratio",
           "choose_fixed_channels", "choose_gate_filter", "choose_grade", "choose_grade_start", "choose_gyro",
           "choose_gyro_kalman_start", "choose_gyro_map", "choose_gyro_order", "choose_gyro_sideslip",
           "choose_gyro_start", "choose_gyro_stops", "choose_log_gaps", "choose_smoother_passes",
           "choose_smoother_settled", "choose_loud_gate",
           "choose_lowpass", "choose_gate_at_source", "choose_read_at_source",
           "choose_quiet_gyro", "gyro_sim_sets", "QUIET_GYRO_OFFSETS", "held_logs", "HELD_RATES_HZ",
           "choose_source_rounding", "quiet_noise_sets", "rounded_logs", "ROUNDINGS", "SOURCE_ROUNDING_SIM_NOISE",
           "choose_noise_at_source",
           "choose_noise_octave", "choose_noise_tau", "choose_octave_top", "choose_pitch_anchor",
           "choose_pitch_bandwidth", "choose_pitch_rate", "choose_pitch_start", "choose_prior_again",
           "choose_quiet_floor_rate", "choose_quiet_floor_signal", "choose_quiet_measure", "choose_roll_check",
           "choose_roll_check_again", "choose_short_check", "choose_smoother", "choose_unbiased_after_anchor",
           "choose_unbiased_gyro", "choose_unbiased_gyro_again", "choose_unbiased_offset_again",
           "choose_unbiased_start", "design_settings", "fixed", "gap_sets", "gate_filter_sets", "guarded",
           "gyro_objective",
           "gyro_sets", "kinematic_pif_candidates", "lengths_objective", "log_errors", "long_errors", "long_logs",
           "long_median", "loud_gate_candidates", "loud_sets", "lowest_tied", "objective", "paper_median", "paper_sets",
           "per_log", "prior_candidates", "resampled_logs", "rms_deg", "sets_objective", "short_rows", "sim_errors",
           "simulated_sets", "smoother_clip_candidates", "training_logs", "training_pitch_rates",
           "unbiased_pitch_objectives", "upsampled_logs", "whole_and_pieces", "with_gaps", "without_roll_rate"]
