"""``roadbank identify`` can be tried from the command line: ``roadbank simulate identification-drive``
drives the test-track procedure of docs/identification.md, and the worked example there runs as
written and gives the numbers it shows."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.sim import SCENARIOS
from roadbank.sim.scenarios import DRIVES
from roadbank.vehicle import load_vehicle

DOC = Path(__file__).resolve().parents[1] / "docs" / "identification.md"


def _worked_example() -> tuple[list[str], str]:
    """The commands of the doc's worked example and the section's text."""
    text = DOC.read_text()
    section = text[text.index("### Worked example"):]
    section = section[:section.index("\n## ")]
    block = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    return [ln for ln in block.splitlines() if ln.startswith("roadbank ")], section


@pytest.fixture(scope="module")
def worked(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("identify")
    commands, section = _worked_example()
    assert [c.split()[1] for c in commands] == ["simulate", "identify"]
    runner = CliRunner()
    outputs = []
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(cwd)
        for cmd in commands:
            res = runner.invoke(main, shlex.split(cmd)[1:])
            assert res.exit_code == 0, (cmd, res.output)
            outputs.append(res.output)
    return cwd, outputs, section


def test_worked_example_recovers_the_simulated_cars_stiffness(worked):
    cwd, _, _ = worked
    truth = load_vehicle("sedan").params
    got = load_vehicle(cwd / "my-sedan.toml")
    for name in ("Cf", "Cr"):
        value, std = got.identified[name]["value"], got.identified[name]["std"]
        assert getattr(got.params, name) == value
        assert abs(value / getattr(truth, name) - 1) < 0.05, (name, value, getattr(truth, name))
        assert abs(value - getattr(truth, name)) < 3 * std, (name, value, std)
    # every quantity was identified (exit code 0), the offsets (none injected) near zero
    assert set(got.identified) == {"Cf", "Cr", "Kus", "steering_offset", "yaw_rate_offset", "ay_offset"}
    assert abs(got.identified["ay_offset"]["value"]) < 3 * got.identified["ay_offset"]["std"]


def test_worked_example_shows_what_the_commands_print(worked):
    _, outputs, section = worked
    printed = dict(re.findall(r"^\s+(Cf|Cr|Kus)\s+([0-9.]+ \+- [0-9.]+)", outputs[1], re.M))
    assert set(printed) == {"Cf", "Cr", "Kus"}
    for name, value in printed.items():
        assert f"| `{name}` |" in section and value in section, (name, value)


def test_identification_uses_the_data_not_the_base_files_stiffness(worked, tmp_path):
    cwd, _, _ = worked
    sedan = load_vehicle("sedan")
    wrong = sedan.replace(name="wrong", params=sedan.params.replace(Cf=0.6 * sedan.params.Cf, Cr=1.5 * sedan.params.Cr))
    wrong.to_toml(tmp_path / "wrong.toml")
    res = CliRunner().invoke(main, ["identify", str(cwd / "drive.parquet"), "--vehicle", str(tmp_path / "wrong.toml"),
                                    "-o", str(tmp_path / "out.toml")])
    assert res.exit_code == 0, res.output
    got = load_vehicle(tmp_path / "out.toml").params
    assert abs(got.Cf / sedan.params.Cf - 1) < 0.05 and abs(got.Cr / sedan.params.Cr - 1) < 0.05


def test_the_drive_is_a_simulate_scenario_but_not_part_of_the_paper_study():
    assert "identification-drive" in DRIVES and "identification-drive" not in SCENARIOS
    res = CliRunner().invoke(main, ["simulate", "nope", "-o", "x.csv"])
    assert res.exit_code == 2 and "identification-drive" in res.output
