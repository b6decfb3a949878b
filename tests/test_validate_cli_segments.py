"""``roadbank validate all|comma2k19`` and ``bench``'s accuracy section over several comma2k19 segments: every
segment scored (each once, a second path to one a warning), data sets found at any depth without following a
loop of links, the report's Generated-by line the command with its options.

The segments are folders linking to the shared example segment's ``processed_log`` and ``global_pose`` (two
folders, so two segments); nothing is copied.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.validation.comma2k19 import named_apart, unique_segments
from roadbank.validation.datasets import find_datasets

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
SEGMENT = DATA / "comma2k19-example"
needs_segment = pytest.mark.skipif(not (SEGMENT / "processed_log").is_dir(),
                                   reason=f"the comma2k19 example segment is absent at {SEGMENT}")
QUICK = ["-e", "kinematic,kinematic-pif", "--no-sensitivity"]


def _segment(folder: Path, pose: bool = True) -> Path:
    """A segment folder at ``folder`` whose ``processed_log`` (and ``global_pose``) link to the example's."""
    folder.mkdir(parents=True)
    (folder / "processed_log").symlink_to(SEGMENT / "processed_log")
    if pose:
        (folder / "global_pose").symlink_to(SEGMENT / "global_pose")
    return folder


def _drive(folder: Path) -> Path:
    (folder / "oxts" / "data").mkdir(parents=True)
    (folder / "oxts" / "timestamps.txt").write_text("2011-01-01 12:00:00.0\n")
    return folder


def _two_segments_and_a_link(tmp_path: Path) -> Path:
    """``data/`` with segA, a link to it, segB five levels down and a link from deep inside back to ``data``."""
    data = tmp_path / "data"
    _segment(data / "segA")
    _segment(data / "x" / "y" / "z" / "w" / "segB")
    (data / "link-to-A").symlink_to(data / "segA")
    (data / "x" / "y" / "loop").symlink_to(data)
    return data


# ------------------------------------------------------------------ finding data sets (no data needed)
def test_find_datasets_at_any_depth_and_stops_at_a_loop_of_links(tmp_path):
    for d in ("seg", "a/b/c/d/e/seg2"):
        (tmp_path / d / "processed_log").mkdir(parents=True)
    _drive(tmp_path / "k" / "l" / "m" / "2011_01_01_drive_0001_sync")
    _drive(tmp_path / "2011_01_01_drive_0002_sync")
    (tmp_path / "a" / "b" / "up").symlink_to(tmp_path)          # a loop: ends where it comes back
    (tmp_path / "a" / "b" / "self").symlink_to("self")           # a link to itself: cannot be resolved
    found = find_datasets(tmp_path)
    assert found["comma2k19"] == [tmp_path / "seg", tmp_path / "a/b/c/d/e/seg2"]
    assert [p.name for p in found["kitti"]] == ["2011_01_01_drive_0002_sync", "2011_01_01_drive_0001_sync"]
    assert found["notes"] == []


def test_find_datasets_says_what_lies_below_its_depth_limit(tmp_path):
    (tmp_path / "a/b/c/seg" / "processed_log").mkdir(parents=True)
    found = find_datasets(tmp_path, max_depth=2)
    assert found["comma2k19"] == []
    assert len(found["notes"]) == 1 and "more than 2 levels deep not searched" in found["notes"][0]
    assert find_datasets(tmp_path, max_depth=4)["comma2k19"] == [tmp_path / "a/b/c/seg"]


def test_find_datasets_names_a_folder_it_cannot_list(tmp_path):
    locked = tmp_path / "locked"
    (locked / "seg" / "processed_log").mkdir(parents=True)
    locked.chmod(0)
    try:
        if any(True for _ in _listable(locked)):
            pytest.skip("this user can list a folder without permissions (root)")
        found = find_datasets(tmp_path)
        assert found["comma2k19"] == [] and len(found["notes"]) == 1
        assert str(locked) in found["notes"][0] and "cannot be listed" in found["notes"][0]
    finally:
        locked.chmod(0o755)


def _listable(folder: Path):
    try:
        yield from folder.iterdir()
    except OSError:
        return


def test_a_segment_reached_twice_is_kept_once_with_a_note(tmp_path):
    (tmp_path / "segA" / "processed_log").mkdir(parents=True)
    (tmp_path / "other" / "segA" / "processed_log").mkdir(parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "segA")
    segs, notes = unique_segments([tmp_path / "link", tmp_path / "segA"])
    assert segs == [tmp_path / "link"] and len(notes) == 1
    assert "given more than once" in notes[0] and "scored once" in notes[0] and str(tmp_path / "segA") in notes[0]
    segs, notes = unique_segments([tmp_path / "segA", tmp_path / "other" / "segA"])     # two folders, one name
    assert segs == [tmp_path / "segA", tmp_path / "other" / "segA"] and len(notes) == 1
    assert "two folders hold a comma2k19 segment named segA" in notes[0]


# ------------------------------------------------------------------ the commands on the shared segment
@pytest.mark.slow
@needs_segment
def test_validate_all_scores_every_segment_once_and_warns(tmp_path):
    data = _two_segments_and_a_link(tmp_path)
    out = tmp_path / "report" / "real-data.md"
    res = CliRunner().invoke(main, ["validate", "all", str(data), "-o", str(out), "--no-jitter", "--json"])
    assert res.exit_code == 0, res.output
    assert "Traceback" not in res.output
    report = json.loads(res.stdout)
    assert sorted(report["comma2k19"]) == ["link-to-A", "segB"]           # segA (linked) once, segB 5 deep
    assert report["kitti"] is None and report["errors"] == []
    assert "warning: comma2k19 segment segA given more than once" in res.stderr
    text = out.read_text()
    assert f"_Generated by `roadbank validate all {data} -o {out} --no-jitter --json`" in text
    for label in ("link-to-A", "segB"):
        assert f"| comma2k19 | {label} (offset fitted) |" in text
        assert (out.parent / f"real-data-comma2k19-{label}.png").is_file()


@pytest.mark.slow
@needs_segment
def test_validate_all_names_a_bad_segment_and_scores_the_others(tmp_path):
    data = tmp_path / "data"
    _segment(data / "good")
    _segment(data / "nopose", pose=False)
    out = tmp_path / "r.md"
    res = CliRunner().invoke(main, ["validate", "all", str(data), "-o", str(out), "--no-jitter", "--json"])
    assert res.exit_code == 1 and "Traceback" not in res.output
    report = json.loads(res.stdout)
    assert list(report["comma2k19"]) == ["good"]
    assert len(report["errors"]) == 1 and "nopose" in report["errors"][0] and "global_pose" in report["errors"][0]
    assert "nothing to score: no reference roll" in report["errors"][0]   # read (the pose is optional), not scored
    assert "error: " in res.stderr and "global_pose" in res.stderr
    # one segment scored: the one-segment layout, its figure next to the report
    assert out.with_suffix(".png").is_file() and "## comma2k19 (phone IMU" in out.read_text()


@pytest.mark.slow
@needs_segment
def test_validate_comma2k19_scores_every_segment_under_a_folder(tmp_path):
    data = _two_segments_and_a_link(tmp_path)
    out = tmp_path / "c.md"
    res = CliRunner().invoke(main, ["validate", "comma2k19", str(data), "--json", "-o", str(out), *QUICK])
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    assert sorted(report["segments"]) == ["link-to-A", "segB"] and report["errors"] == []
    assert set(report["segments"]["segB"]) == {"kinematic", "kinematic-pif"}
    assert "warning: comma2k19 segment segA given more than once" in res.stderr
    assert (f"_Generated by `roadbank validate comma2k19 {data} -o {out} -e kinematic,kinematic-pif "
            "--no-sensitivity --json`" in out.read_text())
    # one segment given: the flat {estimator: scores} as before
    one = CliRunner().invoke(main, ["validate", "comma2k19", str(data / "segA"), "--json", *QUICK])
    assert one.exit_code == 0 and set(json.loads(one.stdout)) == {"kinematic", "kinematic-pif"}


@pytest.mark.slow
@needs_segment
def test_bench_accuracy_judges_every_segment(tmp_path):
    from roadbank.bench.accuracy import _real

    targets, notes = _real(_two_segments_and_a_link(tmp_path))
    assert {t.data for t in targets} == {"comma2k19 segment link-to-A", "comma2k19 segment segB"}
    assert any("segA given more than once" in n for n in notes)


def test_named_apart_names_two_segments_of_one_name_by_their_folders():
    class R:
        def __init__(self, label, path):
            self.label, self.settings = label, {"path": path}
    rs = named_apart([R("3", "/a/3"), R("3", "/b/3"), R("4", "/a/4")])
    assert [r.label for r in rs] == ["/a/3", "/b/3", "4"]


KITTI_DRIVE = DATA / "kitti-oxts" / "2011_09_26_drive_0070"      # the shorter shared drive (420 frames)


@pytest.mark.skipif(not (KITTI_DRIVE / "oxts").is_dir(), reason=f"the shared KITTI drive is absent at {KITTI_DRIVE}")
def test_validate_kitti_prints_its_notes_as_warnings_and_its_options(tmp_path):
    (tmp_path / "link").symlink_to(KITTI_DRIVE)
    out = tmp_path / "k.md"
    res = CliRunner().invoke(main, ["validate", "kitti", str(KITTI_DRIVE), str(tmp_path / "link"), "-o", str(out),
                                    "-e", "kinematic-pif", "--no-sensitivity"])
    assert res.exit_code == 0, res.output
    assert "warning: drive link given more than once" in res.stderr and "scored once" in res.stderr
    assert (f"_Generated by `roadbank validate kitti {KITTI_DRIVE} {tmp_path / 'link'} -o {out} -e kinematic-pif "
            "--no-sensitivity`" in out.read_text())
