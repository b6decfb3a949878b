"""Raw CAN logs with a DBC: a simulated run encoded into every supported container, decoded back.

The DBC is built here with cantools; the frames are encoded from a roadbank.sim run
(yaw rate and ay in FRD, speed in km/h on an extended J1939-style id at 50 Hz with
jitter, the steering-wheel angle in a multiplexed message) and written with
python-can's writers (BLF, ASC, TRC, candump, MDF4 bus logging). Truth is the
encoded physical value: decoding must return it within half a quantisation step.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

can = pytest.importorskip("can")
cantools = pytest.importorskip("cantools")
from cantools.database.can import Database, Message, Signal  # noqa: E402
from cantools.database.conversion import BaseConversion  # noqa: E402

from roadbank.io import LogError, load_log, read_channel_map  # noqa: E402
from roadbank.io.can import read_can  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # asammdf on a cut file

T_ORIGIN = 1_700_000_000.0       # absolute epoch time of the first frame
FORMATS = {"blf": ".blf", "asc": ".asc", "trc": ".trc", "candump": ".log", "mdf4-can": ".mf4"}
SCALE = {"YawRate": 0.01, "LatAcc": 0.001, "VehSpd": 1 / 256, "SWA": 0.1}
SPEED_ID = 0x18FEF100


def _sig(name, start, length, scale, signed=True, **kw):
    return Signal(name, start, length, is_signed=signed,
                  conversion=BaseConversion.factory(scale=scale, offset=0.0), **kw)


def make_dbc(path: Path, dyn_length=8, dyn_id=0x130) -> Path:
    """A small car DBC: dynamics (FRD), speed (extended id), multiplexed steering message."""
    msgs = [
        Message(dyn_id, "ESP_Dyn", dyn_length, [_sig("YawRate", 0, 16, SCALE["YawRate"], unit="deg/s"),
                                                 _sig("LatAcc", 16, 16, SCALE["LatAcc"], unit="m/s^2")]),
        Message(SPEED_ID, "CCVS", 8, [_sig("VehSpd", 8, 16, SCALE["VehSpd"], signed=False, unit="km/h")],
                is_extended_frame=True),
        Message(0x0C2, "SAS", 8, [
            Signal("SAS_Mux", 0, 8, is_multiplexer=True),
            _sig("SWA", 8, 16, SCALE["SWA"], unit="deg", multiplexer_ids=[0], multiplexer_signal="SAS_Mux"),
            _sig("SWA_Speed", 8, 16, 1.0, unit="deg/s", multiplexer_ids=[1], multiplexer_signal="SAS_Mux")]),
    ]
    path.write_text(Database(msgs).as_dbc_string())
    return path


MAP = """
dbc = "car.dbc"
convention = "FRD"
steering_ratio = {ratio}
[channels]
speed = {{ message = "CCVS", signal = "VehSpd", unit = "km/h" }}
lateral_acceleration = {{ message = "ESP_Dyn", signal = "LatAcc", unit = "m/s^2" }}
yaw_rate = {{ message = "0x130", signal = "YawRate", unit = "deg/s" }}
steering_wheel_angle = {{ signal = "SWA", unit = "deg", convention = "ISO" }}   # multiplexed
"""


@pytest.fixture(scope="module")
def run():
    from roadbank.sim import run_scenario
    return run_scenario("bank-lane-change", seed=2)


@pytest.fixture(scope="module")
def encoded(run, tmp_path_factory):
    """Frames encoded from the run: (messages, truth) with truth[signal] = (t, physical value)."""
    db = cantools.database.load_file(str(make_dbc(tmp_path_factory.mktemp("dbc") / "car.dbc")))
    s, swa = run.signals, run.steering_wheel_angle
    rng = np.random.default_rng(0)
    dyn, ccvs, sas = (db.get_message_by_name(n) for n in ("ESP_Dyn", "CCVS", "SAS"))
    frames, truth = [], {k: ([], []) for k in SCALE}

    def add(t, msg, values, ext=False):
        frames.append(can.Message(timestamp=T_ORIGIN + t, arbitration_id=msg.frame_id, is_extended_id=ext,
                                  data=msg.encode(values)))
        for k, v in values.items():
            if k in truth:
                truth[k][0].append(t)
                truth[k][1].append(v)

    for k, t in enumerate(s.t):
        add(t, dyn, {"YawRate": -math.degrees(s.r[k]), "LatAcc": -s.ay[k]})        # FRD on the bus
        add(t + 0.003, sas, {"SAS_Mux": k % 2, ("SWA" if k % 2 == 0 else "SWA_Speed"):
                             math.degrees(swa[k]) if k % 2 == 0 else 0.0})
        if k % 2 == 1 and t < s.t[-1] - 0.02:
            add(t + 0.004 * rng.uniform(-1, 1), ccvs, {"VehSpd": s.vx[k] * 3.6}, ext=True)
        if k % 50 == 7:   # a frame the DBC does not know
            frames.append(can.Message(timestamp=T_ORIGIN + t + 0.001, arbitration_id=0x7FF, data=bytes(8)))
    frames.sort(key=lambda m: m.timestamp)
    return frames, {k: (np.array(a), np.array(b)) for k, (a, b) in truth.items()}


@pytest.fixture(scope="module")
def logs(encoded, tmp_path_factory):
    d = tmp_path_factory.mktemp("canlogs")
    make_dbc(d / "car.dbc")
    (d / "car.toml").write_text(MAP.format(ratio=16.0))
    out = {}
    for fmt, suf in FORMATS.items():
        p = d / f"drive{suf}"
        with can.Logger(str(p)) as lg:
            for m in encoded[0]:
                lg.on_message_received(m)
        out[fmt] = p
    return d, out


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_decoded_back_within_quantisation(fmt, logs, encoded):
    d, files = logs
    cmap = read_channel_map(d / "car.toml")
    table, warns = read_can(files[fmt], cmap, fmt)
    _, truth = encoded
    cols = {"YawRate": "0x130.YawRate", "LatAcc": "ESP_Dyn.LatAcc", "VehSpd": "CCVS.VehSpd", "SWA": "SWA"}
    t_first = table.times[cols["YawRate"]][0]    # ASC stores times relative to the first frame
    for sig, col in cols.items():
        t_true, v_true = truth[sig]
        assert len(table.data[col]) == len(v_true), sig
        np.testing.assert_array_less(np.abs(table.data[col] - v_true), SCALE[sig] / 2 + 1e-9)
        np.testing.assert_allclose(table.times[col] - t_first, t_true - truth["YawRate"][0][0], atol=2e-6)
    assert any("0x7FF" in w for w in warns)      # unknown id skipped, and said so


@pytest.mark.parametrize("fmt", ["blf", "mdf4-can"])
def test_load_log_si_iso_on_the_grid(fmt, logs, encoded):
    d, files = logs
    _, truth = encoded
    log = load_log(files[fmt], channels=d / "car.toml")
    s = log.signals
    assert log.format == fmt
    assert abs(s.t[0] - (T_ORIGIN + 0.01)) < 0.02        # absolute time kept, start at the overlap
    assert np.allclose(np.diff(s.t), 0.01, rtol=0, atol=1e-6)   # the map's 100 Hz grid
    tt = s.t - T_ORIGIN

    def expect(sig, factor):      # the encoded physical values, linearly interpolated onto the grid
        return np.interp(tt, truth[sig][0], truth[sig][1]) * factor, SCALE[sig] / 2 * abs(factor) + 1e-9

    # the bus carried FRD deg/s and m/s^2 and km/h; roadbank must give back ISO SI
    for got, (want, tol) in ((s.r, expect("YawRate", -math.pi / 180)), (s.ay, expect("LatAcc", -1.0)),
                             (s.vx, expect("VehSpd", 1 / 3.6)),
                             (s.delta_f, expect("SWA", math.pi / 180 / 16.0))):
        np.testing.assert_allclose(got, want, rtol=0, atol=tol)


# ---------------------------------------------------------------- errors
def _map(d: Path, text: str) -> Path:
    p = d / "bad.toml"
    p.write_text(text)
    return p


def test_missing_signal_names_dbc_message_and_signal(logs):
    d, files = logs
    m = _map(d, MAP.format(ratio=16).replace('signal = "VehSpd"', 'signal = "VehSpeed"'))
    with pytest.raises(LogError, match=r"car\.dbc.*'speed'.*'VehSpeed'.*message 'CCVS'"):
        load_log(files["blf"], channels=m)


def test_unknown_message_id(logs):
    d, files = logs
    m = _map(d, MAP.format(ratio=16).replace('message = "0x130"', 'message = "0x555"'))
    with pytest.raises(LogError, match=r"car\.dbc.*'yaw_rate'.*signal 'YawRate'.*message '0x555'.*unknown"):
        load_log(files["asc"], channels=m)


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_truncated_file(fmt, logs, tmp_path):
    d, files = logs
    data = files[fmt].read_bytes()
    cut = data.rfind(b"\n", 0, 2 * len(data) // 3) + 6 if fmt != "blf" else 2 * len(data) // 3
    bad = tmp_path / files[fmt].name
    bad.write_bytes(data[:cut])
    with pytest.raises(LogError, match=rf"{bad.name}.*(truncated|corrupt)"):
        load_log(bad, channels=d / "car.toml")


def test_wrong_dbc_ids_and_lengths(logs, tmp_path):
    d, files = logs
    (tmp_path / "car.toml").write_text(MAP.format(ratio=16).replace('"0x130"', '"ESP_Dyn"'))
    make_dbc(tmp_path / "car.dbc", dyn_id=0x131)            # another car's ids
    with pytest.raises(LogError, match=r"drive\.trc.*'ESP_Dyn' \(id 0x131\) never occurs.*'yaw_rate' "
                                       r"\(signal 'YawRate'\)"):
        load_log(files["trc"], channels=tmp_path / "car.toml")
    make_dbc(tmp_path / "car.dbc", dyn_length=4)            # same id, other layout
    with pytest.raises(LogError, match=r"drive\.log.*'ESP_Dyn' \(id 0x130\), signal '(YawRate|LatAcc)'.*"
                                       r"8 data byte.*DBC says 4"):
        load_log(files["candump"], channels=tmp_path / "car.toml")
    (tmp_path / "car.dbc").write_text("this is not a DBC\n")
    with pytest.raises(LogError, match=r"car\.dbc: not a readable DBC"):
        load_log(files["blf"], channels=tmp_path / "car.toml")


def test_map_without_dbc(logs, tmp_path):
    d, files = logs
    m = _map(tmp_path, MAP.format(ratio=16).replace('dbc = "car.dbc"', ""))
    with pytest.raises(LogError, match=r"bad\.toml: .*CAN signals.*no dbc"):
        load_log(files["blf"], channels=m)


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_stream_is_the_whole_log(fmt, logs):
    """A raw CAN log streamed is one chunk equal to ``load_log`` (the same source and assembler)."""
    from roadbank.io.stream import stream_log
    d, files = logs
    whole = load_log(files[fmt], channels=d / "car.toml")
    chunks = list(stream_log(files[fmt], channels=d / "car.toml", chunk_rows=50))
    assert len(chunks) == 1
    for k in ("t", "vx", "ay", "r", "delta_f"):
        np.testing.assert_array_equal(getattr(chunks[0].signals, k), getattr(whole.signals, k), err_msg=k)
    assert chunks[0].warnings == whole.warnings and chunks[0].time_repairs == whole.time_repairs


def test_a_map_unit_other_than_the_dbcs_is_named(logs):
    """The DBC states km/h for VehSpd; a map declaring mph for it (a slip the unit checks cannot see: 80 read as mph
    is a plausible speed) is read as the map says (a user's map wins) and warned about naming both units; the map
    that agrees with the DBC says nothing of units."""
    d, files = logs
    (d / "mph.toml").write_text(MAP.format(ratio=16.0).replace('signal = "VehSpd", unit = "km/h"',
                                                               'signal = "VehSpd", unit = "mph"'))
    good = load_log(files["blf"], channels=d / "car.toml")
    assert not [w for w in good.warnings if "the file states" in w]
    bad = load_log(files["blf"], channels=d / "mph.toml")
    said = [w for w in bad.warnings if "the file states" in w]
    assert len(said) == 1 and "the file states 'km/h', the channel map 'mph': read in 'mph'" in said[0], said
    assert "channel 'speed'" in said[0] and "drive.blf" in said[0]
    np.testing.assert_allclose(np.nanmedian(bad.signals.vx) / np.nanmedian(good.signals.vx), 0.44704 * 3.6,
                               rtol=1e-6)


def test_an_asc_line_cut_in_the_middle_is_said(logs, tmp_path):
    """python-can passes over an ASC line cut in the middle without a word; the frames it could not read are
    counted against the lines that start like frames and said, the others read. The whole file says nothing."""
    d, files = logs
    cmap = read_channel_map(d / "car.toml")
    _, warns = read_can(files["asc"], cmap, "asc")
    assert not [w for w in warns if "start like CAN frames" in w], warns
    lines = files["asc"].read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if " 130 " in ln and i > len(lines) // 2)
    lines[k] = lines[k][:lines[k].index(" 130 ") + 4]                  # time, channel, id: then cut
    cut = tmp_path / "cut.asc"
    cut.write_text("\n".join(lines) + "\n")
    (tmp_path / "car.dbc").write_text((d / "car.dbc").read_text())
    whole, _ = read_can(files["asc"], cmap, "asc")
    table, warns = read_can(cut, cmap, "asc")
    said = [w for w in warns if "start like CAN frames" in w]
    assert len(said) == 1 and "1 line(s)" in said[0] and "cut.asc" in said[0], warns
    assert len(table.data["0x130.YawRate"]) == len(whole.data["0x130.YawRate"]) - 1


def test_mdf4_bus_log_without_a_dbc_says_how_to_read_it(logs):
    """An MDF4 bus log (raw CAN frames) read without a channel map: the error says it holds CAN frames that a map
    with a DBC decodes (it listed the frame columns only)."""
    from roadbank.io import LogError
    _, files = logs
    with pytest.raises(LogError, match=r"\.mf4: channel 'speed' .*: it is an MDF4 bus log \(raw CAN frames, "
                                       r"CAN_DataFrame\), read with a DBC: give a channel map with dbc = "):
        load_log(files["mdf4-can"])
