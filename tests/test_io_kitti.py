"""KITTI raw oxts reader: synthetic drives written by the tests (every malformed case) and the real drives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from roadbank.io import LogError, detect_format, load_log
from roadbank.io.kitti import N_FIELDS, find_oxts_dirs

KITTI = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts"
DRIVES = sorted(KITTI.glob("*/oxts")) if KITTI.is_dir() else []
needs_data = pytest.mark.skipif(not DRIVES, reason=f"KITTI oxts drives absent at {KITTI}")


def frame_values(k: int) -> np.ndarray:
    """30 distinct, recognisable values for frame k (column j holds j / 100 + k / 1000), each plausible
    in its unit (the reader checks them: 0.08 m/s, 0.12 m/s^2, 0.19 rad/s, a roll of 0.03 rad)."""
    return 0.01 * np.arange(N_FIELDS) + k / 1000.0


def write_drive(root: Path, n: int = 6, stamps=None) -> Path:
    """A KITTI-layout drive folder ``root/drive_sync/oxts`` with n frames at 10 Hz; returns the drive folder."""
    oxts = root / "2011_01_01_drive_0001_sync" / "oxts"
    (oxts / "data").mkdir(parents=True)
    if stamps is None:
        stamps = [f"2011-01-01 12:00:{k // 10:02d}.{(k % 10) * 100_000_000 + 123:09d}" for k in range(n)]
    (oxts / "timestamps.txt").write_text("\n".join(stamps) + "\n")
    for k in range(n):
        (oxts / "data" / f"{k:010d}.txt").write_text(" ".join(f"{v:.6f}" for v in frame_values(k)) + "\n")
    (oxts / "dataformat.txt").write_text("lat: latitude of the oxts-unit (deg)\n")
    return oxts.parent


def test_columns_time_and_detection(tmp_path):
    drive = write_drive(tmp_path)
    for p in (drive, drive / "oxts", tmp_path):          # drive folder, oxts folder, parent of one drive
        assert detect_format(p) == "kitti-oxts"
        log = load_log(p)
        s = log.signals
        assert log.format == "kitti-oxts" and log.metadata["drive"] == "2011_01_01_drive_0001_sync"
        # 10 Hz from the nanosecond stamps, relative to the first frame
        np.testing.assert_allclose(s.t, 0.1 * np.arange(6), atol=1e-6)
        k = np.arange(6) / 1000.0
        np.testing.assert_allclose(s.vx, 0.08 + k)          # column 8 vf
        np.testing.assert_allclose(s.ay, 0.12 + k)          # column 12 ay
        np.testing.assert_allclose(s.r, 0.19 + k)           # column 19 wz
        np.testing.assert_allclose(log.reference_roll, 0.03 + k)    # column 3 roll
        np.testing.assert_allclose(log.extra["lat_deg"], k)
        np.testing.assert_allclose(log.extra["lon_deg"], 0.01 + k)
        np.testing.assert_allclose(log.extra["vl_mps"], 0.09 + k)   # column 9 vl
        assert np.all(np.isnan(s.delta_f))
        assert log.metadata["time_origin"] == "2011-01-01 12:00:00.000000123 UTC"
        assert log.metadata["dropped_frames"] == "0"
    assert load_log(drive, format="kitti-oxts").signals.vx[0] == 0.08


def test_parent_of_two_drives_is_refused_by_load_log_but_found(tmp_path):
    write_drive(tmp_path)
    other = tmp_path / "b"
    write_drive(other)
    (other / "2011_01_01_drive_0001_sync").rename(tmp_path / "2011_01_01_drive_0002_sync")
    assert len(find_oxts_dirs(tmp_path)) == 2
    with pytest.raises(LogError, match="holds 2 KITTI drives"):
        load_log(tmp_path, format="kitti-oxts")


def test_missing_frame_is_dropped_and_counted(tmp_path):
    drive = write_drive(tmp_path, n=8)
    (drive / "oxts" / "data" / "0000000003.txt").unlink()
    log = load_log(drive)
    assert log.metadata["dropped_frames"] == "1" and len(log) == 7
    # the other frames keep their own time stamps: a 0.2 s step where frame 3 was
    np.testing.assert_allclose(np.diff(log.signals.t), [0.1, 0.1, 0.2, 0.1, 0.1, 0.1], atol=1e-6)
    np.testing.assert_allclose(log.signals.vx, 0.08 + np.array([0, 1, 2, 4, 5, 6, 7]) / 1000.0)
    assert any("0000000003.txt" in w and "dropped" in w for w in log.warnings)


@pytest.mark.parametrize("blank", [[0], [2, 3], [3]])
def test_a_frame_whose_time_stamp_was_lost_is_dropped_and_counted(tmp_path, blank):
    """A blank line inside timestamps.txt (KITTI's recordings lost data now and then) is a frame without a stamp: it
    is dropped, its data file there or not, and counted, with a warning naming the file and the first line; every
    other frame keeps its own absolute stamp (before: the whole drive refused). The time origin is the first frame
    kept."""
    stamps = [f"2011-01-01 12:00:00.{k}00000000" for k in range(8)]
    for k in blank:
        stamps[k] = ""
    drive = write_drive(tmp_path, n=8, stamps=stamps)
    if len(blank) > 1:
        (drive / "oxts" / "data" / f"{blank[1]:010d}.txt").unlink()          # its data lost too
    log = load_log(drive)
    kept = [k for k in range(8) if k not in blank]
    assert log.metadata["dropped_frames"] == str(len(blank)) and len(log) == len(kept)
    np.testing.assert_allclose(log.signals.t, (np.array(kept) - kept[0]) / 10.0, atol=1e-6)
    np.testing.assert_allclose(log.signals.vx, 0.08 + np.array(kept) / 1000.0)
    assert log.metadata["time_origin"] == f"2011-01-01 12:00:00.{kept[0]}00000000 UTC"
    assert any(f"timestamps.txt: {len(blank)} blank line(s) (first: line {blank[0] + 1})" in w and "dropped" in w
               for w in log.warnings), log.warnings
    assert not any("missing from the numbering" in w for w in log.warnings)


def test_frames_past_the_last_time_stamp_are_dropped_and_counted(tmp_path):
    """timestamps.txt shorter than the frames (its last lines lost): the frames past it are dropped and counted with
    a warning naming the first; the others keep their stamps. Most frames without a stamp is refused
    (test_malformed_drive_names_file_and_line: not the drive's time stamps)."""
    drive = write_drive(tmp_path, n=8)
    _stamps(drive, (drive / "oxts" / "timestamps.txt").read_text().splitlines()[:6])
    log = load_log(drive)
    assert len(log) == 6 and log.metadata["dropped_frames"] == "2"
    np.testing.assert_allclose(log.signals.vx, 0.08 + np.arange(6) / 1000.0)
    assert any("timestamps.txt has 6 lines: 2 frame file(s) after them (first: 0000000006.txt)" in w
               for w in log.warnings), log.warnings


STAMPS = [f"2011-01-01 12:00:00.{k}00000000" for k in range(8)]
REPAIRED = {    # timestamps.txt -> (frames kept in time order, the warning's words)
    "swapped pair": (STAMPS[:3] + [STAMPS[4], STAMPS[3]] + STAMPS[5:], [0, 1, 2, 4, 3, 5, 6, 7],
                     "1 swapped pair reordered (first at frame 3)"),
    "repeated stamp": (STAMPS[:4] + [STAMPS[3]] + STAMPS[5:], [0, 1, 2, 3, 5, 6, 7],
                       "1 duplicate stamp dropped (first at frame 3)"),
    "repeated across a lost stamp": (STAMPS[:3] + ["", STAMPS[2]] + STAMPS[5:], [0, 1, 2, 5, 6, 7],
                                     "1 duplicate stamp dropped (first at frame 2)"),
}


@pytest.mark.parametrize("case", sorted(REPAIRED))
def test_stamps_out_of_order_are_repaired_as_in_every_log(tmp_path, case):
    """A repeated or swapped stamp in timestamps.txt is mended by the one rule of every reader
    (roadbank.io.timebase.repair_time: a repeat dropped, a swapped pair put back in order, the frames next to a
    repair flagged), with the warning naming the file and the frame (before: the drive refused). KITTI's unsynced
    100 Hz oxts stamps hold such repeats."""
    stamps, kept, words = REPAIRED[case]
    log = load_log(write_drive(tmp_path, n=8, stamps=stamps))
    tenths = {k: int(stamp[-9]) for k, stamp in enumerate(stamps) if stamp}       # frame -> its stamp (0.1 s)
    t = np.round(log.signals.t * 10).astype(int)                                  # frame 0's stamp is 0
    np.testing.assert_array_equal(t, sorted(tenths[k] for k in kept))
    ok = np.isfinite(log.signals.vx)
    frames = np.round((log.signals.vx[ok] - 0.08) * 1000).astype(int)             # the frame each value came from
    np.testing.assert_array_equal([tenths[k] for k in frames], t[ok])             # each value at its own stamp
    assert not ok.all()                                                           # the frames next to it flagged
    assert any("timestamps.txt" in w and words in w for w in log.warnings), log.warnings


@pytest.mark.parametrize("kept", [14, 29])
def test_a_last_frame_cut_off_is_left_out(tmp_path, kept):
    """The last frame file cut off while the drive was written (14 or 29 of its 30 fields, the last one mid-number):
    left out with a warning naming it, as a CSV's cut last line is (before: the whole drive refused); the other
    frames are read as they are. A frame inside the drive with too few fields is still refused
    (test_malformed_drive_names_file_and_line)."""
    drive = write_drive(tmp_path, n=8)
    last = drive / "oxts" / "data" / "0000000007.txt"
    last.write_text(" ".join(last.read_text().split()[:kept])[:-2])          # the last number cut mid-way
    log = load_log(drive)
    assert len(log) == 7 and log.metadata["dropped_frames"] == "1"
    np.testing.assert_allclose(log.signals.vx, 0.08 + np.arange(7) / 1000.0)
    assert any("0000000007.txt: the last frame holds" in w and f"{kept} of its 30 fields" in w and "left out" in w
               for w in log.warnings), log.warnings


def _wrong_fields(d):
    (d / "oxts/data/0000000002.txt").write_text(" ".join(["1.0"] * 29) + "\n")


def _non_numeric(d):
    vals = [f"{v}" for v in frame_values(2)]
    vals[12] = "1.2.3"
    (d / "oxts/data/0000000002.txt").write_text(" ".join(vals) + "\n")


def _empty_frame(d):
    (d / "oxts/data/0000000002.txt").write_text("")


def _two_lines(d):
    line = " ".join(f"{v}" for v in frame_values(2))
    (d / "oxts/data/0000000002.txt").write_text(line + "\n" + line + "\n")


def _stamps(d, lines):
    (d / "oxts/timestamps.txt").write_text("\n".join(lines) + "\n")


GOOD = [f"2011-01-01 12:00:00.{k}00000000" for k in range(6)]

MALFORMED = {
    "wrong field count": (_wrong_fields, r"0000000002\.txt: line 1: 29 fields, expected 30"),
    "non-numeric field": (_non_numeric, r"0000000002\.txt: line 1: field 12 is not a number: '1\.2\.3'"),
    "empty frame file": (_empty_frame, r"0000000002\.txt: expected one line of 30 values, found 0"),
    "two lines in a frame": (_two_lines, r"0000000002\.txt: expected one line of 30 values, found 2"),
    "unparsable time stamp": (lambda d: _stamps(d, GOOD[:3] + ["2011-01-01 12:00:0x.3"] + GOOD[4:]),
                              r"timestamps\.txt: line 4: unparsable time stamp"),
    "impossible date": (lambda d: _stamps(d, GOOD[:1] + ["2011-02-30 12:00:00.1"] + GOOD[2:]),
                        r"timestamps\.txt: line 2: unparsable time stamp"),
    "only blank time stamps": (lambda d: _stamps(d, ["", "  ", ""] + [" "] * 3), r"timestamps\.txt: no time stamps"),
    "every stamp the same": (lambda d: _stamps(d, [GOOD[0]] * 6),
                             r"\(column 'timestamps\.txt'\): no increasing time base: all 6 stamps equal"),
    "no time stamps": (lambda d: _stamps(d, []), r"timestamps\.txt: no time stamps"),
    "most frames without a time stamp": (lambda d: _stamps(d, GOOD[:2]),
                                         r"0000000002\.txt: frame 2 has no time stamp .*2 lines for 6 frame files"),
    "fewer than two frames": (lambda d: [f.unlink() for f in sorted((d / "oxts/data").iterdir())[1:]],
                              r"1 frame file\(s\); at least 2"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_drive_names_file_and_line(tmp_path, case):
    drive = write_drive(tmp_path, n=6, stamps=GOOD)
    breaker, pattern = MALFORMED[case]
    breaker(drive)
    with pytest.raises(LogError, match=pattern):
        load_log(drive)


def test_not_a_drive(tmp_path):
    with pytest.raises(LogError, match="neither a comma2k19 segment .* nor a KITTI raw drive"):
        load_log(tmp_path)
    with pytest.raises(LogError, match="not a KITTI raw drive"):
        load_log(tmp_path, format="kitti-oxts")


# README of ../shared/data/kitti-oxts: frames, duration, roll range, jitter, sign checks
README_FACTS = {"2011_10_03_drive_0047": (837, 86.6, (-2.4, 3.5), 0.94, 0.96),
                "2011_09_26_drive_0070": (420, 43.3, (-2.3, 4.3), 0.89, 0.94)}


@needs_data
@pytest.mark.parametrize("oxts", DRIVES, ids=lambda p: p.parent.name)
def test_real_drive_matches_its_readme(oxts):
    log = load_log(oxts.parent)
    s = log.signals
    frames, duration, (lo, hi), c_turn, c_roll = README_FACTS[oxts.parent.name]
    assert len(s) == frames and log.metadata["dropped_frames"] == "0"
    assert s.t[-1] == pytest.approx(duration, abs=0.1)
    dt = np.diff(s.t)
    assert 0.055 < dt.min() and dt.max() < 0.145 and np.median(dt) == pytest.approx(0.1, abs=0.002)
    roll = np.degrees(log.reference_roll)
    assert roll.min() == pytest.approx(lo, abs=0.05) and roll.max() == pytest.approx(hi, abs=0.05)
    # ISO signs: left turns give positive ay and yaw rate; roll follows the kinematic bank
    assert np.corrcoef(s.ay, s.vx * s.r)[0, 1] == pytest.approx(c_turn, abs=0.01)
    assert np.corrcoef(log.reference_roll, (s.ay - s.vx * s.r) / 9.81)[0, 1] == pytest.approx(c_roll, abs=0.01)
    assert 48.9 < log.extra["lat_deg"].min() and log.extra["lon_deg"].max() < 8.6   # Karlsruhe
    assert log.warnings == []


def test_implausible_values_are_refused_naming_the_frame_channel(tmp_path):
    """The assembler checks a drive's values in their unit as any log's: a speed column of 800 m/s
    (column 8 of every frame) is refused, naming the drive, the channel and the oxts column."""
    drive = write_drive(tmp_path, n=6, stamps=GOOD)
    for k in range(6):
        vals = frame_values(k)
        vals[8] = 800.0 + k
        (drive / "oxts" / "data" / f"{k:010d}.txt").write_text(" ".join(f"{v:.6f}" for v in vals) + "\n")
    with pytest.raises(LogError, match=r"oxts: channel 'speed' \(column 'vf \(column 8\)'\): median speed 80"):
        load_log(drive)


def test_streamed_drive_reads_frames_chunk_by_chunk(tmp_path):
    """Streamed, the frames come ``chunk_rows`` at a time, end to end the whole drive, with the row
    numbers of the frame files; a bad frame in a later chunk is the whole drive's error, once reached."""
    from roadbank.io.stream import stream_log
    drive = write_drive(tmp_path, n=25)
    (drive / "oxts" / "data" / "0000000007.txt").unlink()
    whole = load_log(drive)
    chunks = list(stream_log(drive, chunk_rows=5))
    assert [len(c) for c in chunks] == [5, 5, 5, 5, 4]
    np.testing.assert_array_equal(np.concatenate([c.signals.t for c in chunks]), whole.signals.t)
    np.testing.assert_array_equal(np.concatenate([c.extra["vl_mps"] for c in chunks]), whole.extra["vl_mps"])
    assert chunks[0].warnings == whole.warnings and whole.metadata["dropped_frames"] == "1"
    (drive / "oxts" / "data" / "0000000021.txt").write_text("1 2 3\n")
    got = []
    with pytest.raises(LogError, match=r"0000000021\.txt: line 1: 3 fields, expected 30"):
        for c in stream_log(drive, chunk_rows=5):
            got.append(c)
    assert sum(len(c) for c in got) <= 15              # the chunks before the bad frame's


@pytest.mark.skipif(not (KITTI / "2011_09_26_drive_0070").is_dir(), reason="../shared/data/kitti-oxts not present")
def test_a_channel_map_given_for_a_drive_is_said_to_be_unused(tmp_path):
    """A KITTI drive is read with its format's own channels: a channel map given with it is not used, and the
    reader says so instead of passing over it; without one, no such warning."""
    drive = KITTI / "2011_09_26_drive_0070"
    m = tmp_path / "m.toml"
    m.write_text('[channels]\ntime = { column = "t", unit = "s" }\nspeed = { column = "v", unit = "km/h" }\n'
                 'lateral_acceleration = { column = "a", unit = "m/s^2" }\n'
                 'yaw_rate = { column = "w", unit = "rad/s" }\n')
    said = [w for w in load_log(drive, channels=m).warnings if "the channel map is not used" in w]
    assert len(said) == 1 and "kitti-oxts" in said[0] and drive.name in said[0]
    assert not [w for w in load_log(drive).warnings if "channel map" in w]
