"""Damaged result files of every kind (multi-position with a held-out pose, rotational INS, gyro-free IMU, Allan,
attitude), written by the CLI from simulated recordings: any entry inside a field replaced by another JSON value,
then every command that reads the file (report, apply, export, design) ends in a one-line error naming the cause
(exit 2) or works (exit 0; an exported Kalibr file holds no inf or nan)."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from optinav.cli.main import main


def _run(argv) -> None:
    assert main(["--quiet", *argv]) == 0, argv


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The result files, the recordings they came from and the commands that read them ({bad}: the damaged file,
    {tmp}: a scratch folder)."""
    d = tmp_path_factory.mktemp("results")
    s = str(d)
    _run(
        [
            "simulate",
            "accel-multipos",
            "--out",
            f"{s}/s.csv",
            "--scheme",
            "18",
            "--dwell",
            "8",
            "--seed",
            "3",
            "--acc-unit",
            "counts",
        ]
    )
    _run(["calibrate", "accel", f"{s}/s.csv", "--hold-out", "3", "--out", f"{s}/multipos.json"])
    _run(["simulate", "static", "--out", f"{s}/rest.csv", "--hours", "0.02", "--seed", "1"])
    _run(["allan", f"{s}/rest.csv", "--out", f"{s}/allan.json"])
    nonorth = "--nonorth=-2e-4,-9e-4,-2e-3,7e-4,-8e-4,-9e-3"
    rins = ["--scheme", "dual4", "--align", "60", "--dwell", "10", "--move", "5", "--rate", "100", "--seed", "3"]
    _run(["simulate", "rins", nonorth, *rins, "--out", f"{s}/r.npz"])
    _run(["calibrate", "rins", f"{s}/r.npz", "--out", f"{s}/rins.json"])
    tt = ["--builtin", "cylinder10"]
    _run(["simulate", "gfimu-turntable", *tt, "--rates", "0.5,1.0", "--out", f"{s}/t.npz", "--seed", "1"])
    _run(["calibrate", "gfimu", f"{s}/t.npz", *tt, "--out", f"{s}/gfimu.json"])
    _run(["simulate", "flight", "--kind", "dynamic", "--duration", "5", "--seed", "1", "--out", f"{s}/f.csv"])
    from optinav.attitude import estimate
    from optinav.attitude.unit import AttitudeOptions, read_log

    t, gyr, acc, _, _ = read_log(d / "f.csv", AttitudeOptions())
    estimate(gyr, acc, np.diff(t, prepend=t[0] - (t[1] - t[0])), method="mekf").to_json(d / "attitude.json")
    report = ["report", "{bad}", "--out", "{tmp}/rep"]
    kalibr = ["--to", "kalibr", "--acc-lsb", "2048", "--out", "{tmp}/imu.yaml"]
    commands = {
        "multipos": [
            report,
            ["apply", "{bad}", f"{s}/s.csv", "--out", "{tmp}/o.csv"],
            ["export", "{bad}", "--to", "imucal", "--out", "{tmp}/imucal.json"],
            ["export", "{bad}", "--to", "imu_tk", "--out", "{tmp}/a.calib", "--gyro-out", "{tmp}/g.calib"],
            ["export", "{bad}", *kalibr, "--noise", f"{s}/allan.json"],
        ],
        "allan": [["export", f"{s}/multipos.json", *kalibr, "--noise", "{bad}"], ["design", "--allan", "{bad}"]],
        "rins": [report, ["apply", "{bad}", f"{s}/r.npz", "--out", "{tmp}/o.csv"]],
        "gfimu": [report, ["apply", "{bad}", f"{s}/t.npz", "--out", "{tmp}/o.csv"]],
        "attitude": [["report", "{bad}", "--data", f"{s}/f.csv", "--out", "{tmp}/rep"]],
    }
    return d, commands


def _entries(value, path=(), depth=3):
    """Every entry inside a field's value (itself, the keys of objects, the first and last element of lists)."""
    yield path
    if depth == 0:
        return
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _entries(v, (*path, k), depth - 1)
    elif isinstance(value, list) and value:
        for i in sorted({0, len(value) - 1}):
            yield from _entries(value[i], (*path, i), depth - 1)


def _damage(d: dict, field: str, path: tuple, value) -> dict:
    d = json.loads(json.dumps(d))
    if not path:
        d["fields"][field]["value"] = value
        return d
    t = d["fields"][field]["value"]
    for k in path[:-1]:
        t = t[k]
    t[path[-1]] = value
    return d


def _numbers(v):
    """Every number in a parsed YAML document."""
    if isinstance(v, dict):
        for x in v.values():
            yield from _numbers(x)
    elif isinstance(v, list):
        for x in v:
            yield from _numbers(x)
    elif isinstance(v, (int, float)) and not isinstance(v, bool):
        yield float(v)


def _read_all(files, kind: str, d: dict, tmp: Path, capsys) -> list[str]:
    """Write the damaged result ``d`` of ``kind`` and run every command that reads it: each ends in exit 0 or a
    one-line error (exit 2); the errors are returned."""
    folder, commands = files
    bad = tmp / "bad.json"
    bad.write_text(json.dumps(d))
    capsys.readouterr()
    errors = []
    for cmd in commands[kind]:
        argv = [a.format(bad=bad, tmp=tmp) for a in cmd]
        code = main(["--quiet", *argv])
        err = capsys.readouterr().err.strip()
        if code == 0:
            out = tmp / "imu.yaml"
            if "kalibr" in argv and out.exists():
                numbers = list(_numbers(yaml.safe_load(out.read_text())))
                assert numbers and np.all(np.isfinite(numbers)), (argv, out.read_text())
            continue
        assert code == 2 and err.count("\n") == 0 and err.startswith("optinav: error:"), (argv, code, err)
        errors.append(err)
    return errors


_values = st.sampled_from(
    [None, True, "x", -1, 0, 1e300, -1e300, [], {}, [1.0, 2.0], [None] * 3, ["a"] * 3, [[1.0, 2.0]], "inf", {"a": "x"}]
)
KINDS = {"multipos": "multipos.json", "allan": "allan.json", "rins": "rins.json", "gfimu": "gfimu.json"}
KINDS["attitude"] = "attitude.json"


@pytest.mark.parametrize("kind", sorted(KINDS))
@settings(max_examples=25, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(pick=st.data())
def test_any_entry_of_a_result_damaged_is_read_or_refused_in_one_line(files, tmp_path_factory, capsys, kind, pick):
    d = json.loads((files[0] / KINDS[kind]).read_text())
    where = sorted(
        ((name, p) for name, e in d["fields"].items() for p in _entries(e["value"])),
        key=lambda x: (x[0], [str(k) for k in x[1]]),
    )
    field, path = pick.draw(st.sampled_from(where), label="entry")
    bad = _damage(d, field, path, pick.draw(_values, label="value"))
    _read_all(files, kind, bad, tmp_path_factory.mktemp("damaged"), capsys)


_UNMODIFIED = "pass an unmodified optinav result file"


@pytest.mark.parametrize(
    "kind, field, path, value, named",
    [
        # a whole-number array holding 1e300 overflowed in an internal OverflowError
        ("gfimu", "samples_per_case", (0,), 1e300, "'samples_per_case' holds values that are not whole numbers"),
        (
            "allan",
            "gyroscope",
            ("deviation", "fields", "m", "value", 0),
            1e300,
            "'m' holds values that are not whole numbers, inside 'gyroscope.deviation'",
        ),
        # the held-out pose's numbers went into the summary's formats: an internal TypeError/ValueError
        ("multipos", "quality", ("held_out", "t0_s"), "x", "'quality.held_out.t0_s'"),
        ("multipos", "quality", ("held_out",), -1.0, "'quality.held_out'"),
        ("multipos", "quality", ("n_poses",), 1e300, "'quality.n_poses'"),
        # convergence and gates were not checked at all
        ("multipos", "gates", (0, "passed"), "x", "'gates[0].passed'"),
        ("rins", "convergence", ("iterations",), -1, "'convergence.iterations'"),
        ("gfimu", "gates", (0,), None, "'gates[0]'"),
        # an attitude's q_b_n as null, its pol_skipped counts as text: an internal TypeError in the report; text
        # in its att_std was not named
        ("attitude", "q_b_n", (), None, "'q_b_n'"),
        ("attitude", "att_std", (0,), ["a", "b", "c"], "'att_std'"),
        ("attitude", "gyr_bias", (), [None, None, None], "'gyr_bias'"),
        ("attitude", "pol_skipped", (), {"sky": "x"}, "'pol_skipped.sky'"),
    ],
)
def test_damaged_entries_are_named(files, tmp_path, capsys, kind, field, path, value, named):
    d = json.loads((files[0] / KINDS[kind]).read_text())
    errors = _read_all(files, kind, _damage(d, field, path, value), tmp_path, capsys)
    assert errors
    for err in errors:
        assert f"(field {named}" in err and _UNMODIFIED in err, err


@pytest.mark.parametrize("key", ["accelerometer_noise_density", "gyroscope_random_walk"])
def test_export_kalibr_names_a_noise_key_that_is_null(files, tmp_path, capsys, key):
    """A null noise density in the --noise file passed the loader (null: not estimated) and ended in an internal
    TypeError while the YAML was written: refused naming the key, and no file written."""
    d = json.loads((files[0] / "allan.json").read_text())
    d["fields"]["kalibr"]["value"][key] = None
    errors = _read_all(files, "allan", d, tmp_path, capsys)
    assert errors and all(key in err for err in errors[:1]), errors
    assert not (tmp_path / "imu.yaml").exists()


@pytest.mark.parametrize(
    ("key", "value"),
    [("accelerometer_noise_density", 1e300), ("gyroscope_noise_density", 0.0), ("gyroscope_random_walk", 5.0)],
)
def test_export_kalibr_refuses_a_noise_value_no_imu_has(files, tmp_path, capsys, key, value):
    """1e300 as a noise density in the --noise file was written into Kalibr's imu.yaml as it stood, exit 0; so were
    a zero density and a random walk of 5 rad/s²/√Hz. Each is refused naming the key (an IMU's are far inside 0-1 SI)."""
    d = json.loads((files[0] / "allan.json").read_text())
    d["fields"]["kalibr"]["value"][key] = value
    errors = _read_all(files, "allan", d, tmp_path, capsys)
    assert errors and key in errors[0] and "no IMU's" in errors[0], errors
    assert not (tmp_path / "imu.yaml").exists()


def test_export_kalibr_with_huge_allan_deviations(files, tmp_path, capsys):
    """1e300 in every deviation array of the --noise file: the export writes the file's Kalibr numbers (finite, the
    deviations are not used), or refuses in one line naming the entry; never inf or nan in the YAML."""
    d = json.loads((files[0] / "allan.json").read_text())
    for sensor in ("accelerometer", "gyroscope"):
        dev = d["fields"][sensor]["value"]["deviation"]["fields"]
        for name in ("adev", "lower", "upper", "edf"):
            dev[name]["value"] = np.full(np.shape(dev[name]["value"]), 1e300).tolist()
    assert _read_all(files, "allan", d, tmp_path, capsys) == []
    text = (tmp_path / "imu.yaml").read_text()
    noise = yaml.safe_load(text)
    assert noise["gyroscope_noise_density"] == d["fields"]["kalibr"]["value"]["gyroscope_noise_density"]


def test_a_gfimu_direction_of_1e300_is_named_in_one_line(files, tmp_path, capsys):
    """A calibrated sensing direction of 1e300 overflowed in its norm: a RuntimeWarning line before the error that
    names the direction's norm (inf)."""
    d = json.loads((files[0] / "gfimu.json").read_text())
    d["fields"]["directions"]["value"][0][2] = -1e300
    errors = _read_all(files, "gfimu", d, tmp_path, capsys)
    assert any("accelerometer 1: sensing direction has norm inf" in e for e in errors), errors
