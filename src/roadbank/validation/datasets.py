"""Where the real data sets are under a folder: comma2k19 segments and KITTI drives at any depth
(:func:`find_datasets`), for ``validate all``, ``validate kitti`` and the benchmark's accuracy section."""

from __future__ import annotations

from pathlib import Path

from ..io.kitti import find_oxts_dirs


#: how deep :func:`find_datasets` looks under its folder (levels of folders below it)
MAX_DEPTH = 8
#: folders :func:`find_datasets` never looks into: the inside of a comma2k19 segment or a KITTI drive
_INSIDE = {"processed_log", "global_pose", "oxts"}


def _subfolders(d: Path, notes: list[str]) -> list[Path]:
    """The folders in ``d`` (links to folders too), or none with a note when ``d`` cannot be listed."""
    try:
        return [p for p in d.iterdir() if p.name not in _INSIDE and p.is_dir()]
    except OSError as exc:
        notes.append(f"{d}: cannot be listed ({exc.strerror or exc}): not searched")
        return []


def find_datasets(root, max_depth: int = MAX_DEPTH) -> dict:
    """comma2k19 segments and KITTI drive folders at any depth under ``root`` (down to ``max_depth``
    levels of folders below it).

    A comma2k19 segment is a folder holding ``processed_log/`` or ``global_pose/``
    (:mod:`roadbank.io.comma2k19`; one lacking the other is listed too, so that validating it names what
    is missing); every one found is listed. A KITTI drive is a folder holding ``oxts/``; one whose
    ``oxts/`` lacks ``timestamps.txt`` or ``data/`` is listed too (``find_oxts_dirs(..., broken=True)``),
    so that validating it names what is missing instead of passing it over. Neither is looked into.

    Links to folders are followed, but a folder is looked into once (the same folder once links are
    resolved): a link back up the tree ends there. A segment or drive reached by two paths is listed
    under both (:func:`roadbank.validation.comma2k19.unique_segments` and
    :func:`roadbank.validation.kitti.unique_drives` score it once, with a note).

    Returns ``{"comma2k19": [paths], "kitti": [paths], "notes": [str]}``: the folders level by level,
    each level sorted; ``notes`` names a folder that could not be listed and says when folders were
    left unsearched below ``max_depth``.
    """
    root = Path(root)
    found: dict[str, list] = {"comma2k19": [], "kitti": [], "notes": []}
    seen: set[Path] = set()
    level, depth = [root], 0
    while level:
        below = []
        for d in level:
            if (d / "processed_log").is_dir() or (d / "global_pose").is_dir():
                found["comma2k19"].append(d)
            elif d.name != "oxts" and len(find_oxts_dirs(d, broken=True)) == 1 and (d / "oxts").is_dir():
                found["kitti"].append(d)
            else:
                try:
                    key = d.resolve()
                except (OSError, RuntimeError):     # a link that cannot be resolved (a loop of links)
                    continue
                if key not in seen:
                    seen.add(key)
                    below += _subfolders(d, found["notes"])
        depth += 1
        if depth > max_depth:
            if below:
                found["notes"].append(f"{root}: folders more than {max_depth} levels deep not searched "
                                      f"(e.g. {sorted(below)[0]})")
            break
        level = sorted(below)
    return found
