"""The common result layout (docs/results.md): every system's result exposes parameters with value, std, CRLB
std, unit and observability, convergence, quality gates and timing under ``optinav.<system>.<kind>``; simulated
truth in the estimated parameterization compares field by field; the layouts of older versions still load."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from optinav.attitude.estimators import AttitudeEstimate, attitude_truth, estimate
from optinav.attitude.simulate import simulate as simulate_flight
from optinav.cli.main import main
from optinav.core.results import Estimate, Parameter, Result, Truth
from optinav.errors import OptinavError
from optinav.gfimu.array import builtin
from optinav.gfimu.errors import InstallationErrors
from optinav.gfimu.turntable import TurntableCalibration, calibrate, simulate, turntable_truth
from optinav.io import ImuLog, write_imu
from optinav.multipos.calibrate import calibrate as calibrate_session
from optinav.multipos.result import CalibrationResult, session_truth
from optinav.multipos.simulate import simulate as simulate_session
from optinav.rins.calibrate import RinsCalibration

LEGACY = Path(__file__).parent / "data" / "legacy"
COMMON = (
    "schema",
    "version",
    "optinav_version",
    "system",
    "kind",
    "method",
    "elapsed_s",
    "convergence",
    "quality_gates",
    "parameters",
    "fields",
)


def _check_layout(res: Estimate, schema: str) -> dict:
    """The common sections, a JSON round trip that keeps every parameter, and the parameter entries' shape."""
    raw = json.loads(res.to_json())
    assert tuple(raw) == COMMON and raw["schema"] == schema and f"optinav.{raw['system']}.{raw['kind']}" == schema
    assert raw["elapsed_s"] > 0 and set(raw["convergence"]) == {"converged", "iterations", "evaluations", "message"}
    for g in raw["quality_gates"]:
        assert set(g) == {"name", "value", "limit", "unit", "kind", "passed"} and g["passed"]
    for name, p in raw["parameters"].items():
        assert set(p) == {"value", "std", "crlb_std", "unit", "observable", "reason"}, name
        assert p["observable"] or (p["reason"] and p["value"] is None or name in ("yaw", "q_b_n")), name
    back = Result.from_json(res.to_json())
    assert type(back) is type(res)
    a, b = res.parameters(), back.parameters()
    assert list(a) == list(b)
    for name in a:
        np.testing.assert_array_equal(np.asarray(a[name].value, float), np.asarray(b[name].value, float))
        assert (a[name].std is None) == (b[name].std is None) and a[name].unit == b[name].unit
    return raw


def test_multipos_layout_and_truth_field_by_field():
    s = simulate_session(
        "18",
        dwell_s=5.0,
        rate_hz=20.0,
        transition_s=2.0,
        rest_s=3.0,
        lat=np.radians(38.88),
        height_m=35.0,
        acc_unit="counts",
        rng=5,
    )
    res = calibrate_session(s.t, s.acc, s.gyr, acc_unit="counts", lat=np.radians(38.88), height_m=35.0)
    raw = _check_layout(res, "optinav.multipos.calibration")
    assert raw["convergence"]["converged"] is True
    assert {g["name"] for g in raw["quality_gates"]} >= {"acc residual rms of |a| - g", "gyr optimizer converged"}
    p = res.parameters()
    assert p["acc_K_xx"].crlb_std > 0 and p["acc_K_xx"].std >= p["acc_K_xx"].crlb_std * (1 - 1e-12)
    assert not p["acc_K_zy"].observable and "upper-triangular" in p["acc_K_zy"].reason
    cmp = session_truth(s.acc_K, s.acc_b, s.gyr_K, s.gyr_b, acc_unit="counts").compare(res)
    assert len(cmp) == 21 and max(float(c["z"]) for c in cmp.values()) < 5


def test_gfimu_layout_and_truth_field_by_field():
    arr = builtin("cylinder10")
    e = InstallationErrors.random(arr.n, rng=3)
    data = simulate(arr, e, duration=1.0, rate_hz=100.0, rng=4)
    res = calibrate(arr, data)
    _check_layout(res, "optinav.gfimu.calibration")
    cmp = turntable_truth(e).compare(res)
    assert len(cmp) == 50 and all(res.parameters()[n].crlb_std > 0 for n in cmp)
    # 50 comparisons at 4σ: a wrong std or a biased fit fails
    assert max(float(c["z"]) for c in cmp.values()) < 4, {n: float(c["z"]) for n, c in cmp.items()}


def test_attitude_layout_and_truth_field_by_field():
    d = simulate_flight("static", duration_s=10.0, rate_hz=100.0, rng=3)
    res = estimate(d.gyr, d.acc, 1 / 100, method="mekf", frame=d.frame)
    raw = _check_layout(res, "optinav.attitude.estimate")
    assert raw["convergence"]["converged"] is None  # a filter: nothing to converge
    p = res.parameters()
    assert not p["yaw"].observable and "heading" in p["yaw"].reason and p["gyr_bias"].unit == "rad/s"
    cmp = attitude_truth(d.q_b_n, d.frame).compare(res)
    assert sorted(cmp) == ["pitch", "roll"]  # the heading is not observable without magnetometer/polarization
    # MPU-6000 accelerometer noise (400 µg/√Hz at 100 Hz: 0.028 m/s², 0.16° of tilt per sample): the first,
    # levelled sample is off by up to 3σ ≈ 0.5°, the filtered estimate well below one sample's σ on average
    for name in ("roll", "pitch"):
        err = np.degrees(np.abs(cmp[name]["error"]))
        assert err.max() < 0.5 and np.sqrt(np.mean(err**2)) < 0.16, (name, err.max())


def test_truth_round_trip_and_compare_rules():
    q = np.array([[0.6, 0.8, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]])
    t = Truth(
        "toy",
        {
            "a": Parameter(np.pi - 0.01, "rad"),
            "b": Parameter(2.0, "m"),
            "q_b_n": Parameter(q, ""),
            "hidden": Parameter(5.0, "m"),
        },
    )
    back = Truth.from_dict(json.loads(t.to_json()))
    assert back.system == "toy" and back.parameters["a"].value == np.pi - 0.01
    np.testing.assert_array_equal(back.parameters["q_b_n"].value, q)

    class Toy(Estimate):
        def parameters(self):
            return {
                "a": Parameter(-np.pi + 0.02, "rad", std=0.01),
                "b": Parameter(2.5, "m", std=0.25),
                "q_b_n": Parameter(-q, ""),
                "hidden": Parameter(None, "m", observable=False, reason="toy"),
            }

    cmp = back.compare(Toy())
    assert sorted(cmp) == ["a", "b", "q_b_n"]  # an unobservable parameter is not compared
    assert cmp["a"]["error"] == pytest.approx(0.03) and cmp["a"]["z"] == pytest.approx(3.0)  # on the circle
    assert cmp["b"]["z"] == pytest.approx(2.0)
    np.testing.assert_allclose(cmp["q_b_n"]["error"], 0.0, atol=1e-15)  # −q is the same rotation
    with pytest.raises(OptinavError):
        Truth.from_dict({"schema": "optinav.unknown", "version": 1})


# --- older layouts still load ----------------------------------------------------------------------------------


def _old(name):
    return json.loads((LEGACY / name).read_text())


def test_legacy_multipos_result_and_truth_load():
    old = _old("multipos_v1.json")
    res = CalibrationResult.from_json(LEGACY / "multipos_v1.json")
    np.testing.assert_array_equal(res.accelerometer["K"], old["accelerometer"]["K"])
    np.testing.assert_array_equal(res.gyroscope["b"], old["gyroscope"]["b"])
    assert res.elapsed_s == old["elapsed_s"] and res.convergence["converged"] is True
    p = res.parameters()
    assert p["acc_K_xx"].value == old["accelerometer"]["K"][0][0] and p["acc_K_xx"].unit == "counts per m/s^2"
    assert p["acc_K_xx"].crlb_std == old["accelerometer"]["crlb_std"][0]
    # the truth of the same simulation, in the old layout, compares field by field with the old result
    truth = Truth.from_json(LEGACY / "multipos_truth_v1.json")
    assert truth.system == "multipos" and truth.info["seed"] == 1
    cmp = truth.compare(res)
    assert len(cmp) == 21 and max(float(c["z"]) for c in cmp.values()) < 5


def test_legacy_rins_result_and_truth_load():
    old = _old("rins_v1.json")
    res = Result.from_json(LEGACY / "rins_v1.json")
    assert isinstance(res, RinsCalibration) and res.angles == old["angles"] and res.elapsed_s == old["elapsed_s"]
    p = res.parameters()
    assert p["eta_y"].value is None and not p["eta_y"].observable
    cmp = Truth.from_json(LEGACY / "rins_truth_v1.json").compare(res)
    assert sorted(cmp) == ["eta_x", "theta_x", "theta_y"]  # the old truth has no combinations
    assert all(float(c["z"]) < 4 for c in cmp.values())


def test_legacy_rins_rmse_read_as_roll_pitch_yaw():
    """Version 1 wrote the attitude RMSE as [pitch, roll, yaw]: read back, they are [roll, pitch, yaw], as the
    same simulation (tests/data/legacy/README.md) gives them now."""
    from optinav.rins.calibrate import attitude_errors, prepare
    from optinav.rins.simulate import simulate as simulate_rins

    old = _old("rins_v1.json")
    res = RinsCalibration.from_json(LEGACY / "rins_v1.json")
    d = simulate_rins(
        [1e-4, -2e-4, 3e-4, -1e-4, 2e-4, 4e-4], scheme="dual4", align_s=60, dwell_s=10, move_s=5, rate_hz=100, rng=4
    )
    now = np.degrees(np.sqrt(np.mean(attitude_errors(prepare(d), np.zeros(6)) ** 2, axis=0)))
    # roll and pitch differ by a factor of 2 here, so a swap would be far outside 2 %
    np.testing.assert_allclose(res.rmse_before_deg, now, rtol=0.02)
    assert res.rmse_before_deg == [old["rmse_before_deg"][i] for i in (1, 0, 2)]
    assert res.rmse_after_deg == [old["rmse_after_deg"][i] for i in (1, 0, 2)]
    assert "[roll, pitch, yaw] deg: before " + f"{res.rmse_before_deg[0]:.4g}" in res.summary()


def test_legacy_gfimu_result_and_truth_load():
    old = _old("gfimu_v1.json")
    res = TurntableCalibration.from_json(LEGACY / "gfimu_v1.json")
    assert res.elapsed_s == old["fields"]["elapsed"]["value"] and res.names == old["fields"]["names"]["value"]
    cmp = Truth.from_json(LEGACY / "gfimu_truth_v1.json").compare(res)
    assert len(cmp) == 50 and max(float(c["z"]) for c in cmp.values()) < 4.5


def test_legacy_attitude_estimate_loads():
    old = _old("attitude_v2.json")
    res = AttitudeEstimate.from_json(LEGACY / "attitude_v2.json")
    np.testing.assert_array_equal(res.q_b_n, old["fields"]["q"]["value"]["__ndarray__"])
    assert res.method == "mekf" and res.elapsed_s == 0.0 and "roll" in res.parameters()
    # re-written in the current layout, it reads back the same
    again = AttitudeEstimate.from_json(res.to_json())
    np.testing.assert_array_equal(again.q_b_n, res.q_b_n)


def test_attitude_estimate_v4_with_the_old_field_names_loads():
    """v4 (plain arrays, fields ``q`` and ``gyro_bias``) reads into v5's ``q_b_n`` and ``gyr_bias``."""
    old = _old("attitude_v4.json")
    assert old["version"] == 4 and {"q", "gyro_bias"} <= set(old["fields"])
    res = AttitudeEstimate.from_json(LEGACY / "attitude_v4.json")
    np.testing.assert_array_equal(res.q_b_n, old["fields"]["q"]["value"])
    np.testing.assert_array_equal(res.gyr_bias, old["fields"]["gyro_bias"]["value"])
    new = json.loads(res.to_json())
    assert new["version"] == AttitudeEstimate.VERSION == 9 and "q_b_n" in new["fields"] and "q" not in new["fields"]
    assert new["parameters"] == old["parameters"]


def test_attitude_estimate_v5_without_the_offset_fraction_loads():
    """v5 (before ``mag_offset_used``) reads into v6 with it None (not reported), the rest as written."""
    old = _old("attitude_v5.json")
    assert old["version"] == 5 and "mag_offset_used" not in old["fields"]
    res = AttitudeEstimate.from_json(LEGACY / "attitude_v5.json")
    np.testing.assert_array_equal(res.q_b_n, old["fields"]["q_b_n"]["value"])
    assert res.mag_offset_used is None and res.method == old["fields"]["method"]["value"]
    assert json.loads(res.to_json())["version"] == 9


def test_attitude_estimate_v6_without_the_hard_iron_offset_loads():
    """v6 (before ``mag_hard_iron``) reads into v9 with it None (none subtracted), the rest as written."""
    old = _old("attitude_v6.json")
    assert old["version"] == 6 and "mag_hard_iron" not in old["fields"]
    res = AttitudeEstimate.from_json(LEGACY / "attitude_v6.json")
    np.testing.assert_array_equal(res.q_b_n, old["fields"]["q_b_n"]["value"])
    assert res.mag_hard_iron is None and not res.mag_hard_iron_fitted
    assert res.mag_offset_used == old["fields"]["mag_offset_used"]["value"]
    new = json.loads(res.to_json())
    assert new["version"] == 9 and new["fields"]["mag_hard_iron"]["value"] is None


def test_attitude_estimate_v7_without_the_online_fit_sample_loads():
    """v7 (before ``mag_hard_iron_from``) reads into v9 with it None (not fitted online), the rest as written."""
    old = _old("attitude_v7.json")
    assert old["version"] == 7 and "mag_hard_iron_from" not in old["fields"]
    res = AttitudeEstimate.from_json(LEGACY / "attitude_v7.json")
    np.testing.assert_array_equal(res.q_b_n, old["fields"]["q_b_n"]["value"])
    np.testing.assert_array_equal(res.mag_hard_iron, [3.0, -1.0, 2.0])
    assert res.mag_hard_iron_from is None and not res.mag_hard_iron_fitted
    new = json.loads(res.to_json())
    assert new["version"] == 9 and new["fields"]["mag_hard_iron_from"]["value"] is None


def test_attitude_estimate_v8_without_the_heading_branch_loads():
    """v8 (before ``pol_branch_rms``; an iframe estimate with polarization from q0) reads into v9 with it None (no
    heading branch decided), the rest as written."""
    old = _old("attitude_v8.json")
    assert old["version"] == 8 and "pol_branch_rms" not in old["fields"] and old["fields"]["pol_used"]["value"] > 0
    res = AttitudeEstimate.from_json(LEGACY / "attitude_v8.json")
    np.testing.assert_array_equal(res.q_b_n, old["fields"]["q_b_n"]["value"])
    assert res.pol_branch_rms is None and res.pol_used == old["fields"]["pol_used"]["value"]
    new = json.loads(res.to_json())
    assert new["version"] == 9 and new["fields"]["pol_branch_rms"]["value"] is None


def test_a_fresh_interpreter_reads_every_file_through_the_base_class():
    """``Result.from_json`` / ``Truth.from_json`` find the system's class without the caller importing it."""
    import subprocess
    import sys

    code = (
        "import sys; from optinav.core.results import Result, Truth; "
        "print([type(Result.from_json(p)).__name__ for p in sys.argv[1:5]], "
        "[Truth.from_json(p).system for p in sys.argv[5:]])"
    )
    files = [
        LEGACY / f
        for f in (
            "multipos_v1.json",
            "rins_v1.json",
            "gfimu_v1.json",
            "attitude_v2.json",
            "multipos_truth_v1.json",
            "rins_truth_v1.json",
            "gfimu_truth_v1.json",
        )
    ]
    out = subprocess.run([sys.executable, "-c", code, *map(str, files)], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == (
        "['CalibrationResult', 'RinsCalibration', 'TurntableCalibration', "
        "'AttitudeEstimate'] ['multipos', 'rins', 'gfimu']"
    )


def test_wrong_class_and_damaged_legacy_files_are_one_line_errors(tmp_path):
    with pytest.raises(OptinavError, match="is not a"):
        CalibrationResult.from_json(LEGACY / "rins_v1.json")
    d = _old("multipos_v1.json")
    del d["accelerometer"]
    del d["gyroscope"]
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(OptinavError):
        CalibrationResult.from_json(tmp_path / "bad.json")


def test_apply_reads_old_and_new_multipos_results(tmp_path):
    old = _old("multipos_v1.json")
    new = tmp_path / "new.json"
    CalibrationResult.from_json(LEGACY / "multipos_v1.json").to_json(new)
    assert json.loads(new.read_text())["schema"] == "optinav.multipos.calibration"
    s = simulate_session("six", dwell_s=2.0, rate_hz=20.0, transition_s=1.0, rest_s=1.0, acc_unit="counts", rng=2)
    data = tmp_path / "d.csv"
    write_imu(data, ImuLog(t=s.t, acc=s.acc, gyr=s.gyr, acc_unit="counts", gyro_unit="rad/s"), gyro_unit="deg/s")
    outs = []
    for k, res in enumerate((LEGACY / "multipos_v1.json", new)):
        out = tmp_path / f"c{k}.npz"
        assert main(["--quiet", "apply", str(res), str(data), "--out", str(out)]) == 0
        outs.append(np.load(out))
    np.testing.assert_array_equal(outs[0]["acc"], outs[1]["acc"])
    np.testing.assert_array_equal(outs[0]["gyro"], outs[1]["gyro"])
    K, b = np.array(old["accelerometer"]["K"]), np.array(old["accelerometer"]["b"])
    np.testing.assert_allclose(outs[0]["acc"], np.linalg.solve(K, (s.acc - b).T).T, rtol=1e-9, atol=1e-9)


# the data classes renamed their fields to the vocabulary of docs/conventions.md (old → new)
RENAMED = {
    "imu_truth_v1.json": ("optinav.core.simulate", "ImuTruth", {"omega_ib_b": "gyr", "f_b": "acc"}),  # old names
    "imu_log_v1.json": ("optinav.io.imu", "ImuLog", {"gyro": "gyr"}),  # old names
    "imu_model_v1.json": (
        "optinav.core.imu_model",
        "ImuModel",
        {
            "gyro": "gyr",
            "accel": "acc",  # old names
            "accel_noise": "acc_noise",  # old names
            "sample_rate": "rate_hz",
        },
    ),  # old names
    "imu_model_v2.json": (
        "optinav.core.imu_model",
        "ImuModel",
        {
            "accel_noise": "acc_noise",  # old names
            "sample_rate": "rate_hz",
        },
    ),  # old names
    "imu_measurement_v1.json": (
        "optinav.core.imu_model",
        "ImuMeasurement",
        {"gyro": "gyr", "accel": "acc", "accel_saturated": "acc_saturated"},
    ),  # old names
    "imu_spec_v1.json": (
        "optinav.core.imu_model",
        "ImuSpec",
        {
            "sample_rate": "rate_hz",
            "accel_vrw": "acc_vrw",  # old names
            "accel_bias": "acc_bias",
            "accel_lsb": "acc_lsb",
        },
    ),  # old names
    "multipos_session_v1.json": (
        "optinav.multipos.simulate",
        "SimulatedSession",
        {"gyro": "gyr", "gyro_K": "gyr_K", "gyro_b": "gyr_b"},
    ),  # old names
    "ferraris_v1.json": (
        "optinav.multipos.ferraris",
        "FerrarisCalibration",
        {"gyro_K": "gyr_K", "gyro_G": "gyr_G", "gyro_b": "gyr_b"},
    ),  # old names
    "solar_position_v1.json": ("optinav.sky.sun", "SolarPosition", {"height": "height_m"}),  # old names
    "alignment_v1.json": (
        "optinav.core.alignment",
        "AlignmentResult",
        {"accel_bias": "acc_bias", "accel_bias_std": "acc_bias_std"},
    ),  # old names
    "flight_data_v1.json": (
        "optinav.attitude.simulate",
        "FlightData",
        {"q_true": "q_b_n", "height": "height_m"},
    ),  # old names
    "rins_data_v1.json": ("optinav.rins.simulate", "RinsData", {"h": "height_m", "c_b_n": "C_b_n"}),
}  # old names


def _same(got, want):
    """``got`` (read back) equals ``want`` (a value in the layout of versions before plain arrays)."""
    if isinstance(want, dict) and "__ndarray__" in want:
        np.testing.assert_array_equal(got, np.asarray(want["__ndarray__"], dtype=want["dtype"]))
        assert got.dtype == np.dtype(want["dtype"])
    elif isinstance(want, dict) and "fields" in want:  # a nested result (ImuModel's triads)
        for k, e in want["fields"].items():
            _same(getattr(got, k), e["value"])
    elif isinstance(want, dict) and "__float__" in want:
        assert repr(got) == want["__float__"]
    elif isinstance(want, dict):
        assert set(got) == set(want)
        for k in want:
            _same(got[k], want[k])
    elif isinstance(want, list):
        assert len(got) == len(want)
        for g, w in zip(got, want):
            _same(g, w)
    else:
        assert got == want


# --- arrays as plain lists (docs/results.md) ------------------------------------------------------------------

#: fields renamed since (AttitudeEstimate v5)
ATTITUDE_RENAMED = {"q": "q_b_n", "gyro_bias": "gyr_bias"}

#: RESULT.json of each system in the version before arrays became plain lists (``{"__ndarray__"}``)
PREVIOUS = {
    "multipos_v2.json": CalibrationResult,
    "rins_v2.json": RinsCalibration,
    "gfimu_v2.json": TurntableCalibration,
    "attitude_v3.json": AttitudeEstimate,
}


@pytest.mark.parametrize("name", sorted(PREVIOUS))
def test_results_of_the_version_before_plain_arrays_load(name):
    from optinav.core.results import PLAIN_ARRAYS_SINCE

    old, cls = _old(name), PREVIOUS[name]
    assert old["version"] == PLAIN_ARRAYS_SINCE[old["schema"]] - 1 <= cls.VERSION - 1
    res = Result.from_json(LEGACY / name)
    assert type(res) is cls
    for k, e in old["fields"].items():
        _same(getattr(res, ATTITUDE_RENAMED.get(k, k)), e["value"])
    new = json.loads(res.to_json())
    assert new["version"] == cls.VERSION and "__ndarray__" not in res.to_json()
    assert new["parameters"] == old["parameters"] and new["quality_gates"] == old["quality_gates"]


def _ndarray_layout(d: dict, versions: dict) -> dict:
    """``d`` (a ``to_dict``) as the version before plain arrays wrote it: each array as ``{"__ndarray__", "dtype"}``
    (NaN as ``{"__float__"}`` inside, as that writer did), nested results likewise."""
    from optinav.core.results import _entry_value

    def old(v):
        if isinstance(v, np.ndarray):
            return {"__ndarray__": old(v.tolist()), "dtype": str(v.dtype)}
        if isinstance(v, float) and not np.isfinite(v):
            return {"__float__": repr(v)}
        if isinstance(v, Result):
            return _ndarray_layout(v.to_dict(), versions)
        if isinstance(v, dict):
            return {k: old(x) for k, x in v.items()}
        if isinstance(v, list):
            return [old(x) for x in v]
        return v

    fields = {k: {"value": old(_entry_value(e)), "unit": e["unit"]} for k, e in d["fields"].items()}
    return {"schema": d["schema"], "version": versions[d["schema"]] - 1, "fields": fields}


def test_every_data_class_reads_its_version_before_plain_arrays():
    """The data classes of the four systems, written as the version before plain arrays did, read back equal."""
    from optinav.core.results import PLAIN_ARRAYS_SINCE
    from optinav.core.simulate import six_positions, static_positions
    from optinav.rins.simulate import simulate as simulate_rins

    s = simulate_session("six", dwell_s=0.3, rate_hz=10.0, transition_s=0.3, rest_s=0.2, acc_unit="counts", rng=1)
    objs = [
        static_positions(
            six_positions(frame="enu")[:2], 0.2, 10.0, np.radians(30), height_m=100, transition=0.2, frame="enu"
        ),
        s.log(),
        simulate_flight("static", 0.3, 10, rng=1),
        simulate_rins(scheme="dual4", align_s=0.2, dwell_s=0.2, move_s=0.2, rate_hz=10, rng=1),
    ]
    for obj in objs:
        d = obj.to_dict()
        old = _ndarray_layout(d, PLAIN_ARRAYS_SINCE)
        assert "__ndarray__" in json.dumps(old) and old["version"] == type(obj).VERSION - 1
        back = Result.from_dict(json.loads(json.dumps(old)))
        assert type(back) is type(obj) and back.to_json() == obj.to_json(), type(obj).__name__


@dataclasses.dataclass(eq=False)
class _Arrays(Result):
    SCHEMA = "optinav.test_arrays"
    VERSION = 1

    x: np.ndarray = dataclasses.field(metadata={"unit": "m"})
    nested: dict = dataclasses.field(metadata={"unit": "-"})
    items: list = dataclasses.field(metadata={"unit": "-"})


def test_arrays_are_plain_lists_read_back_exactly():
    """Arrays are nested lists of numbers (NaN null, ±inf "inf"/"-inf"); the field's ``arrays`` names each one's
    path and dtype; a plain JSON reader gets the numbers, ``from_json`` the same arrays back."""
    x = np.array([[1.5, np.nan], [np.inf, -np.inf]])
    nested = {
        "K": np.eye(3),
        "labels": np.arange(4, dtype=np.int32),
        "a/b": {"ok": np.array([True, False])},
        "c": np.array([1 + 2j]),
        "names": np.array(["roll", "yaw"]),
        "empty": np.zeros(0),
        "plain": [1, 2.5],
    }
    items = [np.array([0.25]), {"q": np.array([1.0, 0.0, 0.0, 0.0])}, 3]
    text = _Arrays(x=x, nested=nested, items=items).to_json()
    raw = json.loads(text)["fields"]
    assert "__ndarray__" not in text
    assert raw["x"] == {"value": [[1.5, None], ["inf", "-inf"]], "unit": "m", "arrays": {"": "float64"}}
    assert raw["nested"]["value"]["K"] == np.eye(3).tolist() and raw["nested"]["value"]["plain"] == [1, 2.5]
    assert raw["nested"]["arrays"] == {
        "K": "float64",
        "labels": "int32",
        "a~1b/ok": "bool",
        "c": "complex128",
        "names": "<U4",
        "empty": "float64",
    }
    assert raw["items"]["arrays"] == {"0": "float64", "1/q": "float64"}
    back = Result.from_json(text)
    np.testing.assert_array_equal(back.x, x)
    for k in ("K", "labels", "c", "names", "empty"):
        assert back.nested[k].dtype == nested[k].dtype
        np.testing.assert_array_equal(back.nested[k], nested[k])
    np.testing.assert_array_equal(back.nested["a/b"]["ok"], [True, False])
    assert back.nested["plain"] == [1, 2.5] and back.items[2] == 3 and back.items[1]["q"].dtype == float
    assert back.to_json() == text
    # a damaged or hostile "arrays" is a one-line error, never a traceback or an object array
    for arrays in ({"nope/1": "float64"}, {"": "object"}, {"": "V8"}, ["x"], {"": "no such dtype"}):
        bad = json.loads(text)
        bad["fields"]["x"]["arrays"] = arrays
        with pytest.raises(OptinavError):
            Result.from_json(json.dumps(bad))
    with pytest.raises(OptinavError, match="JSON cannot carry"):
        _Arrays(x=np.array([object()]), nested={}, items=[]).to_json()


@pytest.mark.parametrize("name", sorted(RENAMED))
def test_legacy_data_classes_load_under_their_new_field_names(name):
    import importlib

    mod, cls_name, rename = RENAMED[name]
    cls = getattr(importlib.import_module(mod), cls_name)
    old = _old(name)
    assert old["version"] < cls.VERSION and set(rename) <= set(old["fields"])
    res = Result.from_json(LEGACY / name)  # through the base class: the schema finds the class
    assert type(res) is cls
    for o, n in rename.items():
        _same(getattr(res, n), old["fields"][o]["value"])
    # re-written, it is the current version under the new names and reads back the same
    again = json.loads(res.to_json())
    assert again["version"] == cls.VERSION and set(rename.values()) <= set(again["fields"])
    assert not set(rename) & set(again["fields"])
    assert cls.from_json(res.to_json()).to_json() == res.to_json()


# --- frames of files written before NED became the one default (docs/conventions.md) ----------------------------


def test_old_enu_files_load_as_enu():
    """Files of the former ENU core default name their frame: they read back as ENU, not as today's NED default.
    The v1 ImuTruth is today's ENU simulation of the same call (tests/data/legacy/README.md) to the last bit, and the
    v1 alignment's Euler angles are in the ENU convention of the frame it stores."""
    from optinav.core.alignment import attitude_error
    from optinav.core.rotations import DEFAULT_FRAME, dcm_from_euler
    from optinav.core.simulate import ImuTruth, six_positions, static_positions

    assert DEFAULT_FRAME == "ned"
    tr = ImuTruth.from_json(LEGACY / "imu_truth_v1.json")
    assert _old("imu_truth_v1.json")["fields"]["frame"]["value"] == tr.frame == "enu"
    now = static_positions(
        six_positions(frame="enu")[:2], 0.2, 10.0, np.radians(30), height_m=100, transition=0.2, frame="enu"
    )
    for name in ("C_b_n", "q_b_n", "gyr", "acc", "dtheta", "dv", "vel_n", "pos"):
        np.testing.assert_array_equal(getattr(tr, name), getattr(now, name), err_msg=name)
    al = Result.from_json(LEGACY / "alignment_v1.json")
    assert al.frame == "enu"
    np.testing.assert_allclose(dcm_from_euler(al.euler, al.frame), al.C_b_n, rtol=0, atol=1e-15)
    # the pose it aligned (six_positions()[:1] of the ENU default then): tilt ≈ the drawn unit's bias / g, not 2 rad
    assert np.abs(attitude_error(al.C_b_n, six_positions(frame="enu")[0])).max() < 0.02
    assert np.abs(attitude_error(al.C_b_n, six_positions(frame="ned")[0])).max() > 2.0


def test_nav_solution_frame_as_written_and_enu_when_missing():
    """A NavSolution file keeps the frame it names; one without ``frame`` (optinav always wrote it) reads as the
    ENU of the former core default, in the current layout and in the version before plain arrays."""
    from optinav.core.results import PLAIN_ARRAYS_SINCE
    from optinav.core.simulate import six_positions, static_positions
    from optinav.core.strapdown import NavSolution, mechanize

    lat = np.radians(30)
    for frame in ("enu", "ned"):
        tr = static_positions(six_positions(frame=frame)[:1], 1.0, 10.0, lat, height_m=100, frame=frame)
        nav = mechanize(tr.dtheta, tr.dv, tr.t, tr.q_b_n[0], tr.vel_n[0], tr.pos[0], frame=frame, vertical="hold")
        assert nav.frame == frame and NavSolution.from_json(nav.to_json()).frame == frame
        # at rest in its frame: the solution's velocity stays zero (a frame mix-up would fall at g)
        assert np.abs(nav.vel_n).max() < 1e-9
    d = nav.to_dict()  # NED, written with its frame
    del d["fields"]["frame"]
    for data in (d, _ndarray_layout(d, PLAIN_ARRAYS_SINCE)):
        back = Result.from_dict(json.loads(json.dumps(data)))
        assert type(back) is NavSolution and back.frame == "enu"
        np.testing.assert_array_equal(back.vel_n, nav.vel_n)
    with pytest.raises(TypeError, match="frame"):
        NavSolution(t=nav.t, q_b_n=nav.q_b_n, vel_n=nav.vel_n, pos=nav.pos)  # built by code, the frame is required


def test_truth_series_written_in_blocks_reads_back(tmp_path):
    """A per-sample truth written block by block is the truth :meth:`Truth.to_json` writes, read back."""
    from optinav.attitude.estimators import TRUTH_UNITS, attitude_truth_series
    from optinav.core.results import TruthSeriesWriter

    q = np.random.default_rng(1).normal(size=(25, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    want = attitude_truth(q, "enu", {"seed": 3})
    path = tmp_path / "x.truth.json"
    with TruthSeriesWriter(path, "attitude", TRUTH_UNITS, {"frame": "enu", "seed": 3}) as w:
        for i in range(0, 25, 7):
            w.write(**attitude_truth_series(q[i : i + 7], "enu"))
    got = Truth.from_json(path)
    assert got.system == "attitude" and got.info == want.info
    for name, p in want.parameters.items():
        assert np.array_equal(got.parameters[name].value, p.value) and got.parameters[name].unit == p.unit
    assert json.loads(path.read_text()) == json.loads(want.to_json())
    assert sorted(x.name for x in tmp_path.iterdir()) == ["x.truth.json"]  # no scratch file left


def test_truth_series_writer_leaves_nothing_on_error(tmp_path):
    from optinav.core.results import TruthSeriesWriter

    with pytest.raises(RuntimeError), TruthSeriesWriter(tmp_path / "x.truth.json", "attitude", {"yaw": "rad"}) as w:
        w.write(yaw=np.zeros(3))
        raise RuntimeError("the simulation failed")
    assert list(tmp_path.iterdir()) == []
