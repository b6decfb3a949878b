"""The Cf, Cr pair ``identify`` writes agrees with the understeer gradient it identified.

When the regression identifies ``Kus`` and ``Cf`` but refuses ``Cr`` (too few yaw transients), the file had kept
the base car's guessed pair, whose understeer gradient (the SUV's 3.58 deg/g) contradicted the identified one
(4.11 +- 0.04 deg/g on a simulated SUV with twice its rear stiffness), in silence. The refused stiffness is now
derived from ``Kus`` and the identified one (and said so), or, where that value is not sane, the base pair is kept
with a warning naming both understeer gradients.
"""

from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner

from roadbank import VehicleParams
from roadbank.cli import main
from roadbank.constants import G
from roadbank.identification import identify
from roadbank.identification.check import SimCase, simulate_case
from roadbank.identification.pair import CONTRADICTS_SIGMA, derive_stiffness, stiffness_pair
from roadbank.identification.results import Quantity, refused
from roadbank.io.writers import write_table
from roadbank.models.bicycle import understeer_gradient
from roadbank.sim.drives import DriveSpec
from roadbank.vehicle import Vehicle

DEG_PER_G = math.degrees(G)
P = VehicleParams()          # the paper's SUV: Cf 115, Cr 396.8 kN/rad, Kus 3.58 deg/g
#: four corners, no lane change: Kus and Cf are identified, Cr is not (relative uncertainty 22 % to 109 %)
FEW_TRANSIENTS = DriveSpec(n_corners=4, lane_change_prob=0.0)


def _q(name: str, value: float, std: float, unit: str = "N/rad") -> Quantity:
    return Quantity(name, value, std, unit, "test")


def _quantities(cf: Quantity, cr: Quantity, kus: Quantity) -> dict[str, Quantity]:
    return {"Cf": cf, "Cr": cr, "Kus": kus}


def _cr_refused() -> Quantity:
    return refused("Cr", "N/rad", "Cr not separable from the understeer gradient: relative uncertainty 30 %")


def test_derive_inverts_the_understeer_gradient():
    """From the Kus of a pair and one of its stiffnesses the other comes back; the std is the first-order one."""
    true = P.replace(Cr=2.0 * P.Cr)
    kus = understeer_gradient(true)
    cr, s_cr = derive_stiffness("Cr", _q("Kus", kus, 7e-5, "rad s^2/m"), _q("Cf", true.Cf, 2e3), P)
    cf, _ = derive_stiffness("Cf", _q("Kus", kus, 7e-5, "rad s^2/m"), _q("Cr", true.Cr, 2e4), P)
    assert cr == pytest.approx(true.Cr, rel=1e-12) and cf == pytest.approx(true.Cf, rel=1e-12)
    # first order: moving Cf by its sigma moves Cr by about its share of the propagated sigma
    step, _ = derive_stiffness("Cr", _q("Kus", kus, 7e-5, "rad s^2/m"), _q("Cf", true.Cf + 20.0, 2e3), P)
    d = P.Lr / true.Cf - P.L * kus / P.m
    assert abs(step - cr) / 20.0 == pytest.approx(P.Lf * P.Lr / (d**2 * true.Cf**2), rel=0.01)
    assert s_cr == pytest.approx(cr**2 / P.Lf * math.hypot(P.Lr * 2e3 / true.Cf**2, P.L * 7e-5 / P.m), rel=1e-12)


def test_a_refused_cr_is_derived_so_the_pair_gives_the_identified_kus():
    true = P.replace(Cr=2.0 * P.Cr)
    kus = _q("Kus", understeer_gradient(true), 7e-5, "rad s^2/m")
    params, derived, warnings = stiffness_pair(_quantities(_q("Cf", true.Cf, 2e3), _cr_refused(), kus), P)
    assert warnings == []
    assert params.Cf == true.Cf and params.Cr == pytest.approx(true.Cr, rel=1e-12)
    assert understeer_gradient(params) == pytest.approx(kus.value, rel=1e-12)
    q = derived["Cr"]
    assert q.ok and q.value == params.Cr and q.std > 0 and q.unit == "N/rad"
    assert q.note.startswith("derived, not identified") and "Kus" in q.note and "Cf" in q.note
    assert "relative uncertainty 30 %" in q.note           # why the regression refused it on its own
    assert (params.m, params.Iz, params.Lf, params.Lr, params.k_roll) == (P.m, P.Iz, P.Lf, P.Lr, P.k_roll)


def test_a_refused_cf_is_derived_from_kus_and_cr():
    true = P.replace(Cf=0.8 * P.Cf)
    kus = _q("Kus", understeer_gradient(true), 7e-5, "rad s^2/m")
    cf = refused("Cf", "N/rad", "Cf not separable")
    params, derived, warnings = stiffness_pair(_quantities(cf, _q("Cr", true.Cr, 2e4), kus), P)
    assert warnings == [] and set(derived) == {"Cf"}
    assert params.Cf == pytest.approx(true.Cf, rel=1e-12) and params.Cr == true.Cr
    assert "Lr / (L Kus/m + Lf/Cr)" in derived["Cf"].note


def test_all_three_identified_is_the_identified_pair_as_before():
    kus = _q("Kus", 0.005, 5e-5, "rad s^2/m")
    params, derived, warnings = stiffness_pair(_quantities(_q("Cf", 1.3e5, 2e3), _q("Cr", 3.6e5, 2e4), kus), P)
    assert (params, derived, warnings) == (P.replace(Cf=1.3e5, Cr=3.6e5), {}, [])


def test_no_positive_cr_keeps_the_base_pair_and_warns_with_both_understeer_gradients():
    """A Kus so high that Lr/Cf - L Kus/m < 0: no positive Cr fits; the base pair stays, and the warning names
    the base pair's 3.58 deg/g and the identified Kus."""
    kus = _q("Kus", 0.0085, 8e-5, "rad s^2/m")             # 4.78 deg/g with Cf 115 kN/rad: Cr would be negative
    params, derived, warnings = stiffness_pair(_quantities(_q("Cf", P.Cf, 2e3), _cr_refused(), kus), P)
    assert params == P and derived == {}
    (w,) = warnings
    assert "3.58 deg/g" in w and f"{0.0085 * DEG_PER_G:.3g} +- {8e-5 * DEG_PER_G:.2g} deg/g" in w
    assert "contradicts" in w and "no positive Cr" in w and "kN/rad" in w


def test_a_derived_value_the_file_refuses_keeps_the_base_pair_and_warns():
    kus = _q("Kus", 0.0077, 8e-5, "rad s^2/m")             # Cr 2.2 MN/rad with Cf 119 kN/rad: above 1.5 MN/rad
    params, derived, warnings = stiffness_pair(_quantities(_q("Cf", 1.19e5, 2e3), _cr_refused(), kus), P,
                                               check=lambda p: "outside the plausible range" if p.Cr > 1.5e6 else "")
    assert params == P and derived == {}
    (w,) = warnings
    assert "outside the plausible range" in w and "3.58 deg/g" in w and f"{0.0077 * DEG_PER_G:.3g}" in w
    # the same value without a check: positive, so it is written
    params, derived, _ = stiffness_pair(_quantities(_q("Cf", 1.19e5, 2e3), _cr_refused(), kus), P)
    assert params.Cr > 1.5e6 and set(derived) == {"Cr"}


def test_a_base_pair_that_agrees_with_kus_needs_no_warning():
    kus = _q("Kus", understeer_gradient(P), 1e-4, "rad s^2/m")
    both = _quantities(refused("Cf", "N/rad", "x"), _cr_refused(), kus)
    assert stiffness_pair(both, P) == (P, {}, [])
    off = _q("Kus", understeer_gradient(P) + 1.01 * CONTRADICTS_SIGMA * 1e-4, 1e-4, "rad s^2/m")
    params, derived, (w,) = stiffness_pair(_quantities(refused("Cf", "N/rad", "x"), _cr_refused(), off), P)
    assert params == P and derived == {} and "both refused" in w


def test_kus_refused_leaves_the_base_pair_in_silence():
    kus = refused("Kus", "rad s^2/m", "too few corners")
    assert stiffness_pair(_quantities(_q("Cf", 1.3e5, 2e3), _cr_refused(), kus), P) == (P, {}, [])


# ---- simulated SUVs whose logs give Kus and Cf but not Cr ------------------------------------------------------


def _log_file(tmp_path, scale_rear: float):
    """An SUV plant with ``scale_rear`` times the file's Cr on four corners without a lane change; its parquet
    log and the truth."""
    case = SimCase(scale_front=1.0, scale_rear=scale_rear, drive=FEW_TRANSIENTS, seed=1, with_roll=False)
    log, truth = simulate_case(case)
    s = log.signals
    path = tmp_path / f"rear{scale_rear:g}.parquet"
    write_table(path, {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "delta_f": s.delta_f}, {})
    return case, log, truth, path


def test_identify_derives_the_refused_cr(tmp_path):
    case, log, truth, _ = _log_file(tmp_path, 2.0)
    res = identify([log], case.params)
    q = res.quantities
    assert q["Kus"].ok and q["Cf"].ok and not q["Cr"].ok, q["Cr"]
    assert "needs more yaw transients" in q["Cr"].refused
    assert set(res.derived) == {"Cr"} and res.warnings == []
    assert understeer_gradient(res.params) == pytest.approx(q["Kus"].value, rel=1e-9)
    assert abs(res.derived["Cr"].value - truth["Cr"]) < 3 * res.derived["Cr"].std
    # the base pair it replaces contradicted the identified Kus
    assert abs(understeer_gradient(case.params) - q["Kus"].value) > 10 * q["Kus"].std


def test_cli_writes_the_derived_pair_and_says_so(tmp_path):
    case, _, truth, path = _log_file(tmp_path, 2.0)
    out = tmp_path / "car.toml"
    res = CliRunner().invoke(main, ["identify", str(path), "--vehicle", "suv-paper", "-o", str(out)])
    assert res.exit_code == 1, res.output                  # Cr refused: not everything was identified
    assert "Traceback" not in res.output
    assert "REFUSED" in res.output and "DERIVED" in res.output
    line = next(ln for ln in res.output.splitlines() if "DERIVED" in ln)
    assert line.split()[0] == "Cr" and "kN/rad" in line and "written to the file's [vehicle] Cr" in line
    assert "Cr derived from Kus and Cf" in res.output
    car = Vehicle.from_toml(out)
    kus = car.identified["Kus"]
    assert abs(understeer_gradient(car.params) - kus["value"]) < kus["std"]
    assert car.params.Cf == car.identified["Cf"]["value"]
    cr = car.identified["Cr"]
    assert car.params.Cr == cr["value"] and cr["derived_from"] == ["Kus", "Cf"]
    assert car.rear_measured        # derived from this car's logs: kept as measured too
    assert cr["note"].startswith("derived, not identified") and cr["std"] > 0
    assert "with Cr derived from Kus and Cf" in car.description
    assert not any(ln.startswith("warning: Cf, Cr kept") for ln in res.output.splitlines())
    # --json says the same: Cr refused among the quantities, derived apart
    js = CliRunner().invoke(main, ["identify", str(path), "--vehicle", "suv-paper", "-o", str(tmp_path / "j.toml"),
                                   "--json"])
    got = json.loads(js.stdout)
    assert "refused" in got["quantities"]["Cr"] and got["derived"]["Cr"]["value"] == pytest.approx(car.params.Cr)
    assert got["warnings"] == []


def test_cli_keeps_the_base_pair_and_warns_when_the_derived_cr_is_not_plausible(tmp_path):
    """Three times the file's Cr: the identified Kus and Cf imply Cr of 2.2 MN/rad, above the vehicle file's
    1.5 MN/rad: the base pair stays and the warning names its 3.58 deg/g and the identified Kus."""
    case, _, _, path = _log_file(tmp_path, 3.0)
    out = tmp_path / "car.toml"
    res = CliRunner().invoke(main, ["identify", str(path), "--vehicle", "suv-paper", "-o", str(out)])
    assert res.exit_code == 1 and "Traceback" not in res.output, res.output
    car = Vehicle.from_toml(out)
    assert (car.params.Cf, car.params.Cr) == (case.params.Cf, case.params.Cr)
    assert "Cr" not in car.identified and "DERIVED" not in res.output
    kus = car.identified["Kus"]
    (w,) = [ln for ln in res.output.splitlines() if ln.startswith("warning: Cf, Cr kept")]
    assert "3.58 deg/g" in w and f"{kus['value'] * DEG_PER_G:.3g} +- {kus['std'] * DEG_PER_G:.2g} deg/g" in w
    assert "outside the plausible range" in w and "contradicts" in w and "unit mistake" not in w


def test_identifying_again_with_every_stiffness_replaces_the_derived_one(tmp_path):
    """A file with a derived Cr as the base of a run that identifies Cr: the table is the identified one (no
    derived_from left over) and the description says "Cf, Cr" only."""
    _, _, _, path = _log_file(tmp_path, 2.0)
    first = tmp_path / "first.toml"
    CliRunner().invoke(main, ["identify", str(path), "--vehicle", "suv-paper", "-o", str(first)])
    assert "derived_from" in Vehicle.from_toml(first).identified["Cr"]
    case = SimCase(scale_front=1.0, scale_rear=2.0, seed=1, with_roll=False)      # eight corners, lane changes
    log, truth = simulate_case(case)
    s = log.signals
    full = tmp_path / "full.parquet"
    write_table(full, {"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r, "delta_f": s.delta_f}, {})
    again = tmp_path / "again.toml"
    res = CliRunner().invoke(main, ["identify", str(full), "--vehicle", str(first), "-o", str(again)])
    assert res.exit_code == 0 and "DERIVED" not in res.output, res.output
    car = Vehicle.from_toml(again)
    assert "derived_from" not in car.identified["Cr"] and car.params.Cr == car.identified["Cr"]["value"]
    assert abs(car.params.Cr - truth["Cr"]) < 3 * car.identified["Cr"]["std"]
    assert car.description.endswith("; Cf, Cr identified from logs by roadbank identify")
