"""imucal's real sessions (../shared/data/imucal) through `optinav calibrate accel` by every route, against
imucal's reference calibrations (reference/*.json, imucal 2.6.0)."""

import json
from pathlib import Path

from csv_edit import clip_columns, drift_column
import numpy as np
import pytest

from optinav.cli.main import main
from optinav.core.units import DEG
from optinav.multipos.convert import read_imucal_json
from optinav.multipos.result import CalibrationResult

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal"
pytestmark = pytest.mark.skipif(not (DATA / "annotated_session.csv").is_file(), reason="imucal data absent")
EXAMPLE = [
    "calibrate",
    "accel",
    str(DATA / "example_ferraris_session.csv"),
    "--rate",
    "102.4",
    "--gyro-unit",
    "deg/s",
    "--gravity",
    "9.81",
]
ANNOTATED = [
    "calibrate",
    "accel",
    str(DATA / "annotated_session.csv"),
    "--rate",
    "204.8",
    "--acc-unit",
    "counts",
    "--gyro-unit",
    "counts",
    "--gravity",
    "9.81",
]


def _run(tmp_path, args, code=0, capsys=None):
    out = tmp_path / "r.json"
    assert main(["--quiet", *args, "--out", str(out)]) == code
    return CalibrationResult.from_json(out) if code == 0 else None


def test_example_session_ferraris_from_the_section_list_is_imucal(tmp_path):
    r = _run(
        tmp_path, EXAMPLE + ["--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]
    )
    ref = read_imucal_json(DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").to_optinav()
    np.testing.assert_allclose(r.accelerometer["K"], ref["acc_K"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.gyroscope["K"], ref["gyr_K"], rtol=1e-12)
    np.testing.assert_allclose(r.gyroscope["b"], ref["gyr_b"], rtol=1e-12)


def test_example_session_default_route_agrees_with_imucal(tmp_path, capsys):
    """Norm observation + turns: 6 distinct poses, so the diagonal accelerometer model (with a note); its scales
    within imucal's cross terms (1.5 %) and the gyro scales within 2 % (imucal integrates one 360° turn per axis,
    we every turn between poses)."""
    r = _run(tmp_path, EXAMPLE)
    assert "held at 0" in capsys.readouterr().err
    ref = read_imucal_json(DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").to_optinav()
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), np.diag(ref["acc_K"]), rtol=1e-3)
    np.testing.assert_allclose(np.diag(r.gyroscope["K"]), np.diag(ref["gyr_K"]), rtol=0.02)
    np.testing.assert_allclose(r.gyroscope["b"], ref["gyr_b"], atol=0.01)  # deg/s
    # its turns pass the gyro's residual gate; they show the held terms' shear above the default 1σ (2.1× its
    # prediction): the gyro std follows (χ² scaling, K_yy 0.39 -> 0.55 deg/s per rad/s) and a note says so
    (g,) = [g for g in r.gates if "accelerometer frame's directions" in g["name"]]
    assert g["passed"] and 1.0 < g["value"] < g["limit"] and r.gyroscope["residual_noise_ratio"] > 1.0
    assert r.gyroscope["std_widening"] > 1.1 and any("χ² scaling" in n for n in r.quality["notes"])


def test_annotated_session_turns_are_positive_so_imucal_default_angle_is_refused(tmp_path, capsys):
    """imucal's snapshot of this session (expected_angle −360°) has R_g ≈ −I, a reflected gyro triad; the gate
    names the flag that fixes it, and +360° gives imucal's numbers with the sign of the turns corrected."""
    assert main(["--quiet", *ANNOTATED, "--method", "ferraris", "--out", str(tmp_path / "x.json")]) == 2
    assert "pass --rotation-angle 360" in capsys.readouterr().err
    counts_as_rad = ANNOTATED[: ANNOTATED.index("--gyro-unit")] + ["--gravity", "9.81"]  # gyro read as rad/s
    assert (
        main(
            [
                "--quiet",
                *counts_as_rad,
                "--method",
                "ferraris",
                "--rotation-angle",
                "360",
                "--out",
                str(tmp_path / "y.json"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err  # the README: ~16.7 counts per deg/s
    assert "raw counts? (16." in err and "per deg/s); pass --gyro-unit counts" in err
    r = _run(tmp_path, ANNOTATED + ["--method", "ferraris", "--rotation-angle", "360"])  # sections from the labels
    ref = read_imucal_json(DATA / "reference" / "example_cal_annotated_session.json").to_optinav()
    np.testing.assert_allclose(r.accelerometer["K"], ref["acc_K"], rtol=1e-12)
    np.testing.assert_allclose(r.gyroscope["K"], -ref["gyr_K"], rtol=1e-12)
    np.testing.assert_allclose(np.diag(r.gyroscope["K"]) * DEG, [16.4] * 3, rtol=0.05)  # counts per deg/s


@pytest.mark.parametrize("method", ["ga", "newton"])
def test_annotated_session_in_counts_paper_methods_agree_with_lm(tmp_path, method):
    ref = _run(tmp_path, ANNOTATED + ["--no-gyro"])
    r = _run(tmp_path, ANNOTATED + ["--no-gyro", "--method", method])
    np.testing.assert_allclose(np.diag(r.accelerometer["K"]), np.diag(ref.accelerometer["K"]), rtol=5e-3)
    np.testing.assert_allclose(r.accelerometer["b"], ref.accelerometer["b"], atol=5e-3 * 2048)
    # and both agree with imucal's closed form on the six axis poses to its cross terms
    imucal = read_imucal_json(DATA / "reference" / "example_cal_annotated_session.json").to_optinav()
    np.testing.assert_allclose(np.diag(ref.accelerometer["K"]), np.diag(imucal["acc_K"]), rtol=2e-3)


@pytest.mark.parametrize("rate", [80.0, 120.0, 140.0])
@pytest.mark.parametrize("route", ["ferraris", "default"])
def test_a_wrong_sample_rate_is_refused_by_the_gyro_scale(tmp_path, capsys, rate, route):
    """The example log is 102.4 Hz in deg/s: a --rate off by 17-37 % scales every integrated turn by as much
    (K_xx 43.1 instead of 58.9 raw per rad/s at 140 Hz), which a gyro that reads deg/s cannot be; it used to pass
    the ×1.5 window with exit 0."""
    args = [*EXAMPLE, "--rate", f"{rate:g}"]
    if route == "ferraris":
        args += ["--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]
    _run(tmp_path, args, code=2)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "gyroscope scale" in err and "wrong time base" in err and "--rate" in err
    assert not (tmp_path / "r.json").exists()


@pytest.mark.parametrize("end", ["85 %", "0.6 s short"])
def test_a_ferraris_rotation_section_cut_inside_the_turn_is_refused(tmp_path, capsys, end):
    """imucal's z_rot (a 360° turn about the vertical) labelled only to 85 % of its samples: the closed form
    integrated the rest into K_zz 14 % too large — the turn the gyro makes after the section is the evidence.
    A section 0.6 s short (K_zz 0.79×) was blamed on the time base (--rate, --time-unit)."""
    import json

    sections = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    s = sections["z_rot"]
    if end == "85 %":
        s["end"] = s["start"] + int(0.85 * (s["end"] - s["start"]))
    else:
        s["end"] -= int(0.6 * 102.4)
    path = tmp_path / "sections.json"
    path.write_text(json.dumps(sections))
    _run(tmp_path, [*EXAMPLE, "--method", "ferraris", "--sections", str(path)], code=2)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "the turn of z_rot goes on after it ends" in err and "--sections" in err


@pytest.mark.parametrize("swap", [("x_p", "y_p"), ("y_a", "z_a")])
def test_ferraris_sections_swapped_in_the_list_are_named(tmp_path, capsys, swap):
    """imucal's section list with x_p and y_p swapped was refused as "the six Ferraris poses disagree on g: RMS of
    |a| - g is 8.84e+03 m/s^2" (a helper's finding): the sections whose gravity lies along another axis than their
    names say are named."""
    import json

    sections = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    a, b = swap
    sections[a], sections[b] = sections[b], sections[a]
    path = tmp_path / "sections.json"
    path.write_text(json.dumps(sections))
    _run(tmp_path, [*EXAMPLE, "--method", "ferraris", "--sections", str(path)], code=2)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "the sections do not hold the poses their names say: " in err and "give each section the pose" in err, err
    for nm in swap:
        assert f"{nm}'s gravity lies along " in err, err


@pytest.mark.parametrize(
    "column, limit, stated",
    [("gyr_z", 467.6, None), ("gyr_z", 467.6, "2000"), ("gyr_y", 429.5, None), ("gyr_x", 447.7, None)],
)
def test_a_turn_clipped_below_its_peak_is_refused(tmp_path, capsys, column, limit, stated):
    """imucal's example recording with one gyro column clipped at ±limit deg/s: z at 467.6 (0.6 of its largest value, 3 and
    4 samples of z_rot flat at it) gave K_zz 1.04 % small, 68 std, with exit 0, and so did a range stated too
    large (--gyro-range 2000: the range alone judged the turns); y at 429.5 (one run of 3 samples) K_yy 7 std
    small; x at 447.7 (one sample of x_rot at it, the moves between the poses clipped there too) K_xx 2.2 std. The
    rail a turn's samples show, or the moves between the poses, is now found with or without a range."""
    path = clip_columns(DATA / "example_ferraris_session.csv", tmp_path / "clipped.csv", (column,), limit)
    args = [*EXAMPLE, "--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]
    args[2] = str(path)
    _run(tmp_path, args + (["--gyro-range", stated] if stated else []), code=2)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "the gyroscope is at its full scale" in err and f"section {column[-1]}_rot" in err, err
    assert "the turn was faster than its range" in err and "--gyro-range" in err, err


def test_example_session_ferraris_std_agrees_with_the_norm_route(tmp_path):
    """Ferraris now reports a std (it had none): every K, b and G element has one, and the two routes' scales
    and biases of both triads agree within 3 combined σ on imucal's real session."""
    sections = str(DATA / "example_ferraris_session_list.json")
    fer = _run(tmp_path, [*EXAMPLE, "--method", "ferraris", "--sections", sections]).parameters()
    norm = _run(tmp_path, EXAMPLE).parameters()
    assert all(p.std is not None and p.std > 0 for n, p in fer.items() if "_K_" in n or "_b_" in n or "_G_" in n)
    for n in [f"{s}_K_{a}{a}" for s in ("acc", "gyr") for a in "xyz"] + [
        f"{s}_b_{a}" for s in ("acc", "gyr") for a in "xyz"
    ]:
        z = (fer[n].value - norm[n].value) / np.hypot(fer[n].std, norm[n].std)
        assert abs(z) < 3, (n, z)


def test_annotated_session_gyro_counts_name_their_implied_full_scale(tmp_path, capsys):
    """Counts have no nominal scale to check a wrong --rate against; the note states the full scale the fitted
    K implies for the 16-bit counts — 2000 deg/s (a standard range) at the true 204.8 Hz, half that at 102.4 Hz."""
    import re

    for rate, fs in ((204.8, 2000.0), (102.4, 1000.0)):
        argv = [*ANNOTATED, "--rate", f"{rate:g}", "--method", "ferraris", "--rotation-angle", "360"]
        _run(tmp_path, argv)
        err = capsys.readouterr().err
        m = re.search(r"full scale of ±([\d.]+), ±([\d.]+), ±([\d.]+) deg/s \(x, y, z\) for 16-bit counts", err)
        assert m, err
        np.testing.assert_allclose([float(v) for v in m.groups()], fs, rtol=0.03)


def _labelled_with_time(tmp_path, *, cut: bool, stamp_ms: bool):
    """The example session with a time column and imucal's section names as a label column; ``cut``: only the
    nine sections' rows (their real time stamps, so 4-10 s jumps between sections); ``stamp_ms``: the time in
    whole milliseconds, as loggers write it."""
    import json

    rows = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    names = [n for n in rows.dtype.names if n != "n_samples"]
    sec = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    label = np.full(rows.size, "", dtype=object)
    for k, v in sec.items():
        label[v["start"] : v["end"]] = k
    t = np.arange(rows.size) / 102.4
    keep = label != "" if cut else np.ones(rows.size, bool)
    head = ["t_ms" if stamp_ms else "t", "label", *names]
    lines = [",".join(head)]
    for i in np.flatnonzero(keep):
        ts = f"{round(t[i] * 1000)}" if stamp_ms else repr(float(t[i]))
        lines.append(",".join([ts, label[i], *(repr(float(rows[n][i])) for n in names)]))
    p = tmp_path / "session.csv"
    p.write_text("\n".join(lines) + "\n")
    return [str(p), "--gyro-unit", "deg/s", "--gravity", "9.81", "--method", "ferraris"] + (
        ["--time-unit", "ms"] if stamp_ms else []
    )


@pytest.mark.parametrize("cut, stamp_ms", [(True, False), (False, True), (True, True)])
def test_ferraris_with_time_stamps_is_imucal(tmp_path, cut, stamp_ms):
    """A log cut to its nine sections (imucal's annotated form, with its time stamps): a turn's last sample was
    multiplied by the 10-s jump to the next section (gyro K_xx 60.42 ± 0.11 for imucal's 58.89, exit 0); stamps in
    whole ms at 102.4 Hz (steps of 9 and 10 ms) left K_zz 5σ off. Now imucal's values within a tenth of the std."""
    args = _labelled_with_time(tmp_path, cut=cut, stamp_ms=stamp_ms)
    r = _run(tmp_path, ["calibrate", "accel", *args])
    ref = read_imucal_json(DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").to_optinav()
    std = np.diag(np.asarray(r.gyroscope["K_std"]))
    dev = np.abs(np.diag(r.gyroscope["K"]) - np.diag(ref["gyr_K"]))
    assert np.all(dev < 0.1 * std), (dev, std)


def test_apply_converts_stated_units_and_refuses_a_wrong_gyro_unit(tmp_path, capsys):
    """imucal's example session calibrated in m/s^2 and deg/s, applied to the same log: with its gyro in
    rad/s the corrected gyro was 57x small with exit 0 (the session's turns are about the vertical, which gravity
    does not see; the flips between poses show it); a header declaring g and rad/s, or --acc-unit g, was refused
    ('--acc-unit m/s^2 was passed', which nobody passed). Stated units are converted now."""
    cal = tmp_path / "cal.json"
    args = EXAMPLE + ["--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]
    assert main(["--quiet", *args, "--out", str(cal)]) == 0
    rows = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    acc = np.column_stack([rows[f"acc_{a}"] for a in "xyz"])
    gyr = np.column_stack([rows[f"gyr_{a}"] for a in "xyz"])
    t = np.arange(rows.size) / 102.4

    def write(name, head, a, g):
        p = tmp_path / name
        np.savetxt(p, np.column_stack([t, a, g]), delimiter=",", header=",".join(head), comments="")
        return p

    plain = write("plain.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], acc, gyr)
    rad = write("rad.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], acc, np.radians(gyr))
    units = ["t [s]"] + [f"acc_{a} [g]" for a in "xyz"] + [f"gyr_{a} [rad/s]" for a in "xyz"]
    declared = write("declared.csv", units, acc / 9.80665, np.radians(gyr))

    def apply(data, *extra):
        out = tmp_path / f"out_{data.stem}_{len(extra)}.csv"
        rc = main(["--quiet", "apply", str(cal), str(data), *extra, "--out", str(out)])
        return rc, out

    rc, ref = apply(plain)
    assert rc == 0
    assert apply(rad)[0] == 2
    err = capsys.readouterr().err
    assert "were the data's gyro in rad/s" in err and "--gyro-unit" in err, err
    want = _read_out(ref)
    for data, extra in ((rad, ("--gyro-unit", "rad/s")), (declared, ())):
        rc, out = apply(data, *extra)
        assert rc == 0, capsys.readouterr().err
        got = _read_out(out)
        for c in ("ax", "ay", "az", "gx", "gy", "gz"):
            np.testing.assert_allclose(got[c], want[c], rtol=1e-9, atol=1e-12)


def _read_out(path):
    """An optinav CSV output (its '#' provenance lines skipped) as a structured array by column name."""
    import io

    lines = [ln for ln in Path(path).read_text().splitlines() if not ln.startswith("#")]
    return np.genfromtxt(io.StringIO("\n".join(lines)), delimiter=",", names=True)


def test_apply_refuses_the_session_with_its_accelerometer_x_negated(tmp_path, capsys):
    """imucal's calibration of its example session applied to that log with the accelerometer's x column negated
    wrote the corrected log with exit 0 (y or z negated were refused): its only windows where gravity turns about
    another axis than x are turns about the vertical (not judged: they cannot tell the gyro's unit) and flips by
    180°, whose ends a flipped axis keeps. The axes are judged there too; the log as it is passes unchanged
    (imucal's own corrected rows)."""
    cal = DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json"
    bad = _negated_session(tmp_path, "acc_x")
    out = tmp_path / "out.csv"
    assert main(["--quiet", "apply", str(cal), str(bad), "--rate", "102.4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not explain how gravity turns" in err and "--columns" in err, err
    assert not out.exists()
    # the accelerometer's y negated: the triad with fewer axes off is named first (it was only "gyro x reads -x,
    # gyro z reads -z" and the gyro's columns to fix, a mirror image of the right fix)
    bad = _negated_session(tmp_path, "acc_y")
    assert main(["--quiet", "apply", str(cal), str(bad), "--rate", "102.4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "accelerometer y reads -y" in err, err
    assert "of the accelerometer's (--columns t,ax,-ay,az,gx,gy,gz), or if that triad is right, of the gyro's" in err
    plain = DATA / "example_ferraris_session.csv"
    assert main(["--quiet", "apply", str(cal), str(plain), "--rate", "102.4", "--out", str(out)]) == 0
    got = _read_out(out)
    ref = np.genfromtxt(DATA / "reference" / "ferraris_example_calibrated_head50.csv", delimiter=",", names=True)
    for a in "xyz":
        np.testing.assert_allclose(got[f"a{a}"][:50], ref[f"acc_{a}"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(np.degrees(got[f"g{a}"][:50]), ref[f"gyr_{a}"], rtol=0, atol=1e-9)


def _negated_session(tmp_path, column: str):
    """imucal's example session with one ``column`` negated (a sign wired wrong), as a new file."""
    head, *rows = (DATA / "example_ferraris_session.csv").read_text().splitlines()
    c = head.split(",").index(column)
    flipped = []
    for row in rows:
        v = row.split(",")
        v[c] = repr(-float(v[c]))
        flipped.append(",".join(v))
    bad = tmp_path / f"{column}_negated.csv"
    bad.write_text("\n".join([head, *flipped]) + "\n")
    return bad


ATTITUDE = ["--quiet", "attitude", "--rate", "102.4", "--gyro-unit", "deg/s"]


@pytest.mark.parametrize(
    ("column", "fix"),
    [
        ("acc_x", "t,-ax,ay,az,gx,gy,gz"),
        ("acc_y", "t,ax,-ay,az,gx,gy,gz"),
        ("gyr_x", "t,ax,ay,az,-gx,gy,gz"),
    ],
)
def test_attitude_names_the_one_negated_column_of_the_session(tmp_path, capsys, column, fix):
    """`optinav attitude` on imucal's example session with one column negated. Its 20-s windows hold turns about x
    and about the vertical, where the accelerometer's x negated does not show: exit 0 (the gyro's y and z read
    against gravity's turns there). The accelerometer's y negated was named a mirrored frame (the gyro's three
    signs), the gyro's x named with its y (t,ax,ay,az,-gx,-gy,gz). Judged by the turns about each body axis over
    the whole session (the moves between its six poses), the column negated is named first; the session as
    recorded runs, and its columns so fixed give its attitude (the same output)."""
    out = tmp_path / "a.csv"
    bad = _negated_session(tmp_path, column)
    assert main([*ATTITUDE, str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"(--columns {fix})" in err, err
    assert not out.exists()
    if column == "acc_x":  # the fix in this file's own column order: n_samples,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z
        assert main([*ATTITUDE, str(bad), "--columns=_,gx,gy,gz,-ax,ay,az", "--out", str(out)]) == 0
        fixed = np.genfromtxt(out, delimiter=",", names=True)
        plain = tmp_path / "plain.csv"
        assert main([*ATTITUDE, str(DATA / "example_ferraris_session.csv"), "--out", str(plain)]) == 0
        ref = np.genfromtxt(plain, delimiter=",", names=True)
        assert (
            ref.shape[0] == fixed.shape[0] == len((DATA / "example_ferraris_session.csv").read_text().splitlines()) - 1
        )
        for k in ("qw", "qx", "qy", "qz"):
            np.testing.assert_array_equal(fixed[k], ref[k])


def test_apply_refuses_another_sensors_calibration_by_the_rests(tmp_path, capsys):
    """imucal's calibration of its example session's sensor applied to another sensor's log in the same units
    (imucal's annotated session converted at its nominal 2048 counts per g and 16.4 per deg/s): |a| read
    9.28-10.43 m/s^2 at its rests (the biases 0.5 m/s^2 apart), exit 0 — only the median norm was checked (within
    x2 of g). The rests' |a| must be g within 0.2 m/s^2 (median); the sensor's own session reads 9.8096-9.8106."""
    cal = DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json"
    raw = np.genfromtxt(DATA / "annotated_session.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    acc = np.column_stack([raw[f"acc_{a}"] for a in "xyz"]) / 2048.0 * 9.81
    gyr = np.column_stack([raw[f"gyr_{a}"] for a in "xyz"]) / 16.4
    other = tmp_path / "other.csv"
    t = np.arange(acc.shape[0]) / 204.8
    np.savetxt(other, np.column_stack([t, acc, gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    out = tmp_path / "o.csv"
    assert main(["--quiet", "apply", str(cal), str(other), "--gyro-unit", "deg/s", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "at the log's 7 rests" in err and "another sensor's" in err, err
    assert not out.exists()


def test_mistakes_on_the_real_session_name_the_flag_that_helps(tmp_path, capsys):
    """Errors that named the wrong flag: acc and gyro columns swapped led to '--acc-unit counts' and then
    to a fit that 'did not converge — pass --method lm' (lm in use); twice the rate named --gyro-unit and the
    static intervals, not the time base; swapped rotation sections named only the columns."""
    import json

    rows = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    swap = tmp_path / "swap.csv"
    cols = [rows[f"gyr_{a}"] for a in "xyz"] + [rows[f"acc_{a}"] for a in "xyz"]
    np.savetxt(swap, np.column_stack(cols), delimiter=",", header="ax,ay,az,gx,gy,gz", comments="")
    sec = DATA / "example_ferraris_session_list.json"
    fr = ["--method", "ferraris", "--sections", str(sec)]
    base = [
        "--quiet",
        "calibrate",
        "accel",
        "--gyro-unit",
        "deg/s",
        "--gravity",
        "9.81",
        "--out",
        str(tmp_path / "r.json"),
    ]
    cases = [
        ([str(swap), "--rate", "102.4"], "the two triads look swapped"),
        ([str(swap), "--rate", "102.4", *fr], "the two triads look swapped"),
        ([str(DATA / "example_ferraris_session.csv"), "--rate", "204.8", *fr], "the time base (--rate, --time-unit"),
    ]
    s = json.loads(sec.read_text())
    s["y_rot"], s["z_rot"] = s["z_rot"], s["y_rot"]
    (tmp_path / "sw.json").write_text(json.dumps(s))
    cases.append(
        (
            [
                str(DATA / "example_ferraris_session.csv"),
                "--rate",
                "102.4",
                "--method",
                "ferraris",
                "--sections",
                str(tmp_path / "sw.json"),
            ],
            "the rotation sections' names",
        )
    )
    for argv, needle in cases:
        assert main(base[:3] + argv + base[3:]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and needle in err, (argv, err)


def test_a_time_gap_inside_a_turn_is_noted(tmp_path, capsys):
    """Five rows lost inside x_rot of a log with a time column: imucal's section list (sample indices of the
    whole log) then reached 5 rows past the turn and gyro K_xx came out 1.9 % off with exit 0 and no word."""
    rows = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    keep = np.ones(rows.size, bool)
    keep[6900:6905] = False
    cols = [rows[f"acc_{a}"] for a in "xyz"] + [rows[f"gyr_{a}"] for a in "xyz"]
    f = tmp_path / "gap.csv"
    data = np.column_stack([np.arange(rows.size) / 102.4, *cols])[keep]
    np.savetxt(f, data, delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    args = ["--quiet", "calibrate", "accel", str(f), *EXAMPLE[5:], "--method", "ferraris"]  # EXAMPLE's units, g
    args += ["--sections", str(DATA / "example_ferraris_session_list.json"), "--out", str(tmp_path / "r.json")]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "x_rot: about 5 samples lost inside the turn" in err, err


def _with_empty_rows(tmp_path, rows_from: int, n: int):
    """example_ferraris_session.csv with the cells of ``n`` rows emptied (a logger's dropout written as rows)."""
    lines = (DATA / "example_ferraris_session.csv").read_text().splitlines()
    ncol = lines[0].count(",")
    for i in range(rows_from + 1, rows_from + 1 + n):  # +1: the header
        first = lines[i].split(",")[0]
        lines[i] = first + "," * ncol if first.strip() and not first.startswith("acc") else "," * ncol
    f = tmp_path / "dropout.csv"
    f.write_text("\n".join(lines) + "\n")
    return f


@pytest.mark.parametrize("route", ["ferraris", "lm"])
def test_empty_rows_do_not_shift_sample_index_sections(tmp_path, route):
    """10 empty rows inside pose x_p: they were dropped before imucal's section list (sample indices of the rows
    as written) was read, so every later section pointed 10 rows on — gyro K_zz 1.1 % off, exit 0."""
    sections = ["--sections", str(DATA / "example_ferraris_session_list.json")]
    # the default route with imucal's poses: the accelerometer (its turns about the vertical leave the gyro
    # rank-deficient, a refusal of its own)
    method, sensor = (
        (["--method", "ferraris"], "gyroscope") if route == "ferraris" else (["--no-gyro"], "accelerometer")
    )
    base = _run(tmp_path, EXAMPLE + method + sections)
    f = _with_empty_rows(tmp_path, 700, 10)
    r = _run(tmp_path, ["calibrate", "accel", str(f), *EXAMPLE[3:], *method, *sections])
    np.testing.assert_allclose(r.static_intervals, base.static_intervals, rtol=0, atol=1e-9)  # the same rows
    cal, cal0 = getattr(r, sensor), getattr(base, sensor)
    k, k0 = np.diag(cal["K"]), np.diag(cal0["K"])
    std = np.diag(np.asarray(cal0["K_std"], float))
    assert np.all(np.abs(k - k0) < std), (k, k0, std)


def test_empty_rows_inside_a_turn_widen_its_std(tmp_path, capsys):
    """10 empty rows inside x_rot (0.1 s of a hand turn at ~270 °/s): the gap was bridged with the rate before
    it, 4.3° of the 28.4° it held lost — K_xx 1.2 % off at a std of 0.016 % (74 std), exit 0. The gap
    now takes the mean of the rates on both sides and the std the turn's own rate changes over as long."""
    sections = ["--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]
    base = _run(tmp_path, EXAMPLE + sections)
    f = _with_empty_rows(tmp_path, 6800, 10)
    r = _run(tmp_path, ["calibrate", "accel", str(f), *EXAMPLE[3:], *sections])
    assert "x_rot: about 10 samples lost inside the turn" in capsys.readouterr().err
    k, k0 = r.gyroscope["K"][0][0], base.gyroscope["K"][0][0]
    std = r.gyroscope["K_std"][0][0]
    assert abs(k - k0) < 2 * std and std < 0.02 * k0  # honest, and still a calibration
    # the other axes' turns lost nothing: their scales and std as before
    np.testing.assert_allclose(np.diag(r.gyroscope["K"])[1:], np.diag(base.gyroscope["K"])[1:], rtol=1e-9)


def test_a_time_gap_that_joins_two_poses_is_named(tmp_path, capsys):
    """imucal's session with 2 s of samples lost in the move after its first pose (time column kept): the poses
    on either side became one and the error named only --min-duration (a helper's finding). The gap is named."""
    import pandas as pd

    df = pd.read_csv(DATA / "example_ferraris_session.csv")
    t = df.pop("n_samples").to_numpy() / 102.4
    df.insert(0, "t", t)
    keep = (t < 13.17) | (t >= 15.13)
    f = tmp_path / "gap.csv"
    df[keep].to_csv(f, index=False)
    _run(tmp_path, ["calibrate", "accel", str(f), *EXAMPLE[5:]], code=2)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "distinct pose directions" in err and "the log has 1 time gap(s) (the first 1.9" in err, err
    assert "samples lost in a move join the poses on either side into one" in err


def test_default_route_leaves_out_turns_that_lost_samples(tmp_path, capsys):
    """The default route (norm observation + turns): 4 samples lost in a jerky hand turn (t 50.42-50.46 s, time
    in whole ms) moved gyro K_xx by 6 std with exit 0 and no word. Turns whose duration holds more
    samples than they have are left out with a note; stamps jittered by ±3 ms lose none."""
    rows = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    t = np.arange(rows.size) / 102.4
    cols = [rows[f"acc_{a}"] for a in "xyz"] + [rows[f"gyr_{a}"] for a in "xyz"]

    def run(name, tt, keep):
        f = tmp_path / name
        np.savetxt(
            f, np.column_stack([tt * 1000, *cols])[keep], delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments=""
        )
        out = tmp_path / (name + ".json")
        args = ["--quiet", "calibrate", "accel", str(f), "--time-unit", "ms", *EXAMPLE[5:], "--out", str(out)]
        assert main(args) == 0
        return CalibrationResult.from_json(out), capsys.readouterr().err

    every = np.ones(rows.size, bool)
    clean, err = run("clean.csv", np.round(t * 1000) / 1000, every)
    assert "samples lost" not in err
    lost = every.copy()
    lost[(t >= 50.42) & (t < 50.46)] = False
    r, err = run("lost.csv", np.round(t * 1000) / 1000, lost)
    assert "samples lost (step 0.00977 s) in 1 turn(s)" in err, err
    k, k0, s = (np.diag(np.asarray(x)) for x in (r.gyroscope["K"], clean.gyroscope["K"], r.gyroscope["K_std"]))
    assert np.all(np.abs(k - k0) < 2 * s), (k - k0, s)
    jit = t + np.random.default_rng(0).uniform(-0.003, 0.003, t.size)
    _, err = run("jitter.csv", np.maximum.accumulate(jit) + np.arange(t.size) * 1e-9, every)
    assert "samples lost" not in err, err


def test_a_pose_held_shorter_than_min_duration_is_named(tmp_path, capsys):
    """The second pose cut to 1.9 s: the detection left it out under --min-duration 2 and the error asked to
    'record at least 6 distinct poses' the log holds. It names the short still stretches and the flag."""
    rows = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    t = np.arange(rows.size) / 102.4
    keep = ~((t >= 17.5) & (t < 23.5))
    cols = [rows[f"acc_{a}"][keep] for a in "xyz"] + [rows[f"gyr_{a}"][keep] for a in "xyz"]
    f = tmp_path / "short.csv"
    np.savetxt(f, np.column_stack(cols), delimiter=",", header="ax,ay,az,gx,gy,gz", comments="")
    base = ["--quiet", "calibrate", "accel", str(f), *EXAMPLE[3:], "--out", str(tmp_path / "r.json")]
    assert main(base) == 2
    err = capsys.readouterr().err
    assert "shorter than --min-duration 2 s were left out" in err and "15.6" in err and "--min-duration 1.5" in err, err
    assert main(base + ["--min-duration", "1.5"]) == 0


def test_rows_lost_inside_a_turn_are_placed_by_the_sample_counter(tmp_path, capsys):
    """20 rows deleted at the peak of the annotated session's x_rot (its `samples` counter jumps by 21 there):
    timed at --rate as if contiguous, gyro K_xx came out 6.5 % off with exit 0 and no word. The counter
    places them: the gap is noted and bridged, its std covering the error within the turn's peak bump."""
    args = ANNOTATED[3:] + ["--method", "ferraris", "--rotation-angle", "360"]
    base = _run(tmp_path, ANNOTATED + ["--method", "ferraris", "--rotation-angle", "360"])
    lines = (DATA / "annotated_session.csv").read_text().splitlines()
    del lines[1 + 2796 : 1 + 2816]
    f = tmp_path / "lost.csv"
    f.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    r = _run(tmp_path, ["calibrate", "accel", str(f), *args])
    err = capsys.readouterr().err
    assert "the sample counter skips 20 samples at 1 place(s)" in err and "x_rot: about 20 samples lost" in err
    k, k0, std = r.gyroscope["K"][0][0], base.gyroscope["K"][0][0], r.gyroscope["K_std"][0][0]
    assert abs(k - k0) < 4.5 * std and abs(k - k0) / k0 < 0.02  # was 6.5 % at a std of 0.02 %


FERRARIS = ["--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]


@pytest.mark.parametrize("angle", ["-350", "-330", "180", "-180"])
def test_a_wrong_rotation_angle_is_named_by_the_turns_between_the_poses(tmp_path, capsys, angle):
    """The closed form takes each rotation section as the stated angle, whatever was turned: --rotation-angle
    -350 or -330 on imucal's session (turns about the vertical: the accelerometer cannot see them) gave K_g 3-9 %
    off at 178-530 std with exit 0, and 180 was told "pass -180", which failed on the gyro scale. The
    gyro's turns between the six poses must carry gravity from pose to pose: they give the angle turned."""
    assert main(["--quiet", *EXAMPLE, *FERRARIS, "--rotation-angle", angle, "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pass --rotation-angle -360" in err, err


def test_the_right_rotation_angle_keeps_imucal_and_its_std(tmp_path):
    """At the stated -360° the poses' turns agree (factor 0.9977 ± 0.0011: within twice its std, so K_g's std is
    the closed form's own) and the result is imucal's."""
    r = _run(tmp_path, EXAMPLE + FERRARIS)
    q = r.quality
    assert abs(q["pose_turn_factor"] - 1.0) < 3 * q["pose_turn_factor_std"] < 0.005
    assert np.all(np.diag(r.gyroscope["K_std"]) < 0.01)  # 0.0089-0.0093: nothing added
    assert any(g["name"].startswith("gyr turns between the poses") for g in r.gates)


def test_a_ferraris_log_sampled_too_slowly_for_its_turns_is_refused(tmp_path, capsys):
    """Every 4th row of imucal's session (25.6 Hz, timed by its sample counter at 102.4): the rotations integrate
    short, K_zz 2.7 % off at 174 std with exit 0; the poses' turns need K_g ×1.022: refused, --rate named."""
    import json

    rows = (DATA / "example_ferraris_session.csv").read_text().splitlines()
    f = tmp_path / "dec4.csv"
    f.write_text("\n".join([rows[0], *rows[1::4]]) + "\n")
    sec = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    (tmp_path / "s.json").write_text(
        json.dumps({k: {"start": v["start"] // 4, "end": v["end"] // 4} for k, v in sec.items()})
    )
    args = [*EXAMPLE, "--method", "ferraris", "--sections", str(tmp_path / "s.json")]
    args[2] = str(f)
    assert main(["--quiet", *args, "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the turns integrated over the rotation sections are off by +2" in err
    assert "--rate" in err


@pytest.mark.parametrize("route", ["ferraris", "default"])
def test_a_clipped_accelerometer_axis_is_named_without_acc_range(tmp_path, capsys, route):
    """acc_x clipped at ±9.6 m/s² (pose x_p reads 9.6 in every sample): the Ferraris route gave acc K_xx 0.960
    (imucal 0.997) at 1100 std with exit 0, the default route left the pose out and then advised --min-duration,
    which cannot bring it back. Both name the clipping and the range."""
    rows = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    names = rows.dtype.names
    data = np.column_stack([rows[n] for n in names])
    j = names.index("acc_x")
    data[:, j] = np.clip(data[:, j], -9.6, 9.6)
    f = tmp_path / "clip.csv"
    np.savetxt(f, data, delimiter=",", header=",".join(names), comments="", fmt="%.10g")
    args = [*EXAMPLE, *(FERRARIS if route == "ferraris" else [])]
    args[2] = str(f)
    assert main(["--quiet", *args, "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "clipped at the sensor's range" in err and "--min-duration" not in err
    assert "larger accelerometer range" in err


def test_a_decimated_log_with_a_sample_counter_names_the_rate_of_its_rows(tmp_path, capsys):
    """Every 4th row of the annotated session (its counter steps by 4): --rate is the counter's rate, and 51.2 Hz
    (the rows' rate) gave K_g 3.97× with exit 0 and only a note of skipped samples. The note now says
    which rate --rate was taken as and what to pass if it was the rows'."""
    rows = (DATA / "annotated_session.csv").read_text().splitlines()
    f = tmp_path / "dec4.csv"
    f.write_text("\n".join([rows[0], *rows[1::4]]) + "\n")
    args = [*ANNOTATED, "--method", "ferraris", "--rotation-angle", "360"]
    args[2], args[4] = str(f), "51.2"
    main(["--quiet", *args, "--out", str(tmp_path / "r.json")])
    err = capsys.readouterr().err
    assert "the sample counter steps by 4 on nearly every row" in err and "pass --rate 204.8" in err


@pytest.mark.parametrize("route", [[], ["--method", "ferraris"]])
def test_a_decimated_log_timed_by_its_counter_at_the_rows_rate_is_named(tmp_path, capsys, route):
    """Every 3rd row of imucal's example session (its n_samples counter steps by 3) with --rate 34.13 Hz, the rows'
    rate: --rate is taken as the counter's, the gyro (deg/s) integrates its turns 3× too long, and the error said
    "raw counts? pass --gyro-unit counts" (default route) or named the gyro scale. Timed at the rows' rate the
    calibration passes its gates, so the error now says so and names --rate 102.4; that --rate passes."""
    rows = (DATA / "example_ferraris_session.csv").read_text().splitlines()
    f = tmp_path / "dec3.csv"
    f.write_text("\n".join([rows[0], *rows[1::3]]) + "\n")
    if route:
        secs = json.loads((DATA / "example_ferraris_session_list.json").read_text())
        sec = tmp_path / "dec3.json"
        sec.write_text(json.dumps({k: {e: v // 3 for e, v in se.items()} for k, se in secs.items()}))
        route = [*route, "--sections", str(sec)]
    args = [*EXAMPLE, *route, "--out", str(tmp_path / "r.json")]
    args[2], args[4] = str(f), f"{102.4 / 3:.6g}"
    assert main(["--quiet", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "the sample counter steps by 3" in err and "it passes its gates" in err and "pass --rate 102.4" in err
    assert "--gyro-unit counts" not in err.split("; if ")[-1]
    args[4] = "102.4"
    assert main(["--quiet", *args]) == 0


@pytest.mark.parametrize(("acc_col", "gyr_col"), [("acc_x", "gyr_x"), ("acc_y", "gyr_z")])
def test_one_axis_swapped_between_the_triads_is_named(tmp_path, capsys, acc_col, gyr_col):
    """imucal's annotated session with one accelerometer column and one gyro column swapped: the error said the
    poses disagree on g (check --sections) or hardly turn the axis (record other poses); it names the two
    columns and --columns, by the default method and the Ferraris one."""
    import pandas as pd

    df = pd.read_csv(DATA / "annotated_session.csv")
    df[[acc_col, gyr_col]] = df[[gyr_col, acc_col]].to_numpy()
    path = tmp_path / "swapped.csv"
    df.to_csv(path, index=False)
    args = [a if a != str(DATA / "annotated_session.csv") else str(path) for a in ANNOTATED]
    for extra in ([], ["--method", "ferraris", "--rotation-angle", "360"]):
        capsys.readouterr()
        assert main(["--quiet", *args, *extra, "--out", str(tmp_path / "r.json")]) == 2
        err = capsys.readouterr().err
        words = f"accelerometer's {acc_col[-1]} and the gyroscope's {gyr_col[-1]} columns look swapped"
        assert words in err and "--columns" in err and len(err.strip().splitlines()) == 1, err


def test_imucal_session_as_two_files_on_their_own_clocks(tmp_path, capsys):
    """imucal's session logged as a phone app writes it: the accelerometer and the gyroscope in two files, each with
    its own time stamps (the gyro's 0.3 of a sample later, its values the session's gyro at those times). `calibrate
    accel --gyro` refused them ("resample both files onto the same time stamps"); the gyro is interpolated onto the
    accelerometer's times and the calibration is the one-file calibration's within a tenth of its std."""
    src = DATA / "example_ferraris_session.csv"
    if not src.is_file():
        pytest.skip("imucal data absent")
    raw = np.genfromtxt(src, delimiter=",", names=True)
    rate = 102.4
    t = raw["n_samples"] / rate
    gyr = np.column_stack([raw[f"gyr_{a}"] for a in "xyz"])
    acc = np.column_stack([raw[f"acc_{a}"] for a in "xyz"])
    tg = t[:-1] + 0.3 / rate
    g_at = np.column_stack([np.interp(tg, t, gyr[:, j]) for j in range(3)])
    fa, fg = tmp_path / "Accelerometer.csv", tmp_path / "Gyroscope.csv"
    np.savetxt(fa, np.column_stack([t, acc]), delimiter=",", header="t,ax,ay,az", comments="", fmt="%.10g")
    np.savetxt(fg, np.column_stack([tg, g_at]), delimiter=",", header="t,gx,gy,gz", comments="", fmt="%.10g")
    one = tmp_path / "one.csv"
    np.savetxt(one, np.column_stack([t, acc, gyr]), delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="", fmt="%.10g")  # fmt: skip
    argv = ["--quiet", "calibrate", "accel", "--gyro-unit", "deg/s", "--gravity", "9.81"]
    assert main([*argv, str(one), "--out", str(tmp_path / "one.json")]) == 0
    capsys.readouterr()
    assert main([*argv, str(fa), "--gyro", str(fg), "--out", str(tmp_path / "two.json")]) == 0
    one_r, two_r = (json.loads((tmp_path / f"{n}.json").read_text())["fields"] for n in ("one", "two"))
    for sensor in ("accelerometer", "gyroscope"):
        a, b = one_r[sensor]["value"], two_r[sensor]["value"]
        for key in ("K", "b"):
            std = np.array(a[f"{key}_std"], dtype=float)  # None (held fixed) → NaN: must be equal there
            diff = np.abs(np.asarray(a[key], float) - np.asarray(b[key], float))
            assert np.all(np.where(np.isnan(std), diff <= 1e-12, diff <= 0.1 * std)), (sensor, key, diff, std)
    assert "interpolated onto the time stamps of Accelerometer.csv" in capsys.readouterr().err


def test_a_gyro_file_timed_in_ms_beside_an_accelerometer_file_in_s_is_named(tmp_path, capsys):
    """imucal's session as two files, the gyroscope's time column in ms (no unit in its name) and the
    accelerometer's in s: the gyro's first 0.1 s overlapped the accelerometer's 101 s, were interpolated as a
    constant, and the Ferraris route said 'the gyroscope is at its full scale in 324 samples of the section y_rot'
    (the default route: 'at its full scale at rest'), naming no clock. Each file's clock is judged before they
    are merged; with the unit in the gyro file's column name the calibration is imucal's."""
    raw = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    t = raw["n_samples"] / 102.4
    fa, fg = tmp_path / "acc.csv", tmp_path / "gyr.csv"
    acc = np.column_stack([t] + [raw[f"acc_{a}"] for a in "xyz"])
    np.savetxt(fa, acc, delimiter=",", header="t,ax,ay,az", comments="", fmt="%.12g")
    gyr = np.column_stack([t * 1000.0] + [raw[f"gyr_{a}"] for a in "xyz"])
    np.savetxt(fg, gyr, delimiter=",", header="t,gx,gy,gz", comments="", fmt="%.12g")
    args = ["--quiet", "calibrate", "accel", str(fa), "--gyro", str(fg), *EXAMPLE[5:], *FERRARIS]
    assert main([*args, "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "time column 't' of gyr.csv steps 9.77 s" in err and "--gyro-columns" in err, err
    assert "t_ms" in err
    r = _run(tmp_path, args[1:] + ["--gyro-columns", "t_ms,gx,gy,gz"])
    ref = read_imucal_json(DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").to_optinav()
    np.testing.assert_allclose(r.accelerometer["K"], ref["acc_K"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.gyroscope["K"], ref["gyr_K"], rtol=1e-6)


def test_a_gyro_file_that_starts_later_keeps_the_sample_index_sections_on_their_rows(tmp_path, capsys):
    """imucal's session as two files whose gyroscope starts 10 samples after the accelerometer: those accelerometer
    rows lie outside the gyro's span and are left out, and imucal's section list (indices of the accelerometer
    file's rows) then pointed 10 rows late: gyro K_zz 56.59 for imucal's 57.19 (68 std), K_xx 20 std off, exit 0
    (20 rows: 'the turn of x_rot began before it starts'). Sample indices now count the file's rows: the
    calibration is imucal's; a section wholly among the rows left out is named."""
    raw = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    t = raw["n_samples"] / 102.4
    fa = tmp_path / "acc.csv"
    np.savetxt(fa, np.column_stack([t] + [raw[f"acc_{a}"] for a in "xyz"]), delimiter=",", header="t,ax,ay,az",
               comments="", fmt="%.12g")  # fmt: skip
    gyr = np.column_stack([t] + [raw[f"gyr_{a}"] for a in "xyz"])
    ref = read_imucal_json(DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").to_optinav()
    for late in (10, 1300):
        fg = tmp_path / f"gyr{late}.csv"
        np.savetxt(fg, gyr[late:], delimiter=",", header="t,gx,gy,gz", comments="", fmt="%.12g")
        args = ["calibrate", "accel", str(fa), "--gyro", str(fg), *EXAMPLE[5:], *FERRARIS]
        if late == 10:
            r = _run(tmp_path, args)
            np.testing.assert_allclose(r.accelerometer["K"], ref["acc_K"], rtol=0, atol=1e-9)
            np.testing.assert_allclose(r.gyroscope["K"], ref["gyr_K"], rtol=1e-9)
            np.testing.assert_allclose(r.gyroscope["b"], ref["gyr_b"], rtol=1e-9)
        else:
            capsys.readouterr()
            _run(tmp_path, args, code=2)
            err = capsys.readouterr().err
            assert "section 'x_p' (rows 540-1270) lies where the log has no sample" in err, err


@pytest.mark.parametrize("change, named", [(10, "+6.0% off"), (-50, "-12.0% off")])
def test_rows_repeated_or_lost_inside_a_turn_of_a_log_without_time_are_named(tmp_path, capsys, change, named):
    """imucal's session without its counter, 10 rows inside x_rot written twice (a logger's buffer) or 50 lost, and
    its section list made on the log as it is: the closed form integrated x_rot 6 % long or 12 % short, K_xx 62.40
    or 51.79 for imucal's 58.89 (375 / 762 std) with exit 0 — the gyro's turns between the poses, which check the
    rotation angle, were left out when no common factor on K_g carried gravity ('the rotation angle -360° is
    taken as stated'). A factor per axis does (the others 0.997): x_rot is named."""
    head, *rows = (DATA / "example_ferraris_session.csv").read_text().splitlines()
    rows = [r.split(",", 1)[1] for r in rows]  # no n_samples counter
    at = 6950  # inside x_rot (6770-7093)
    rows = rows[:at] + rows[at - change : at] + rows[at:] if change > 0 else rows[: at + change] + rows[at:]
    f = tmp_path / "log.csv"
    f.write_text("\n".join([head.split(",", 1)[1], *rows]) + "\n")
    secs = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    moved = {n: {k: i + change * (i >= at) for k, i in v.items()} for n, v in secs.items()}
    (tmp_path / "s.json").write_text(json.dumps(moved))
    args = ["calibrate", "accel", str(f), *EXAMPLE[3:], "--method", "ferraris", "--sections", str(tmp_path / "s.json")]
    _run(tmp_path, args, code=2)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"over x_rot is {named}" in err and "rows lost or repeated" in err and "--sections" in err, err


def test_a_drifting_accelerometer_is_refused_on_the_default_route(tmp_path, capsys):
    """imucal's session with acc_z drifting by 0.1 m/s² over its 101 s (warm-up), no --method: the automatic
    threshold takes the most rests whose fit has an acceptable χ², so it left out the two last rests, the ones that
    show the drift, and gave b_z 0.4488 ± 0.0034 (undrifted 0.3983 ± 0.0025) with exit 0. The rest at 94-101 s,
    judged with the calibration, reads |a| 0.048 m/s² off g (10 std; the undrifted session leaves no rest out): an
    error names it and --acc-bias-instability, which then states the drift in the std (b_z 0.449 ± 0.05, exit 0)."""
    path = drift_column(DATA / "example_ferraris_session.csv", tmp_path / "drift.csv", "acc_z", 0.1)
    args = [*EXAMPLE[:2], str(path), *EXAMPLE[3:]]
    assert main(["--quiet", *args, "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert "the accelerometer drifts during the session: the still rest at 93.86" in err and "+z up" in err, err
    assert "--acc-bias-instability" in err and err.count("\n") == 1, err
    assert main(["--quiet", *args, "--acc-bias-instability", "0.05", "--out", str(tmp_path / "r.json")]) == 0
    acc = json.loads((tmp_path / "r.json").read_text())["fields"]["accelerometer"]["value"]
    # the bias went from 0.398 to 0.498 over the session: b_z lies on that way, and its std spans it
    assert 0.3983 < acc["b"][2] < 0.4983 and acc["b_std"][2] >= 0.05, (acc["b"], acc["b_std"])


def _gyro_on_its_own_clock(tmp_path, up: int, down: int, phase: float, add=None):
    """imucal's example recording as two files, each with its time column: the accelerometer at 102.4 Hz and the
    gyroscope resampled to up/down × 102.4 Hz by scipy's polyphase filter (band-limited, as a sensor's decimation
    filter: each turn integrates on the new samples within 0.3e-4 of the original's), its clock ``phase`` s after
    the accelerometer's; ``add`` (section, axis, deg/s, samples): a rate added to that many gyro samples 1.5 s
    into the section. Returns the command's arguments after ``calibrate accel``."""
    from scipy.signal import resample_poly

    rows = np.loadtxt(DATA / "example_ferraris_session.csv", delimiter=",", skiprows=1)
    t = np.arange(rows.shape[0]) / 102.4
    gyr = resample_poly(rows[:, 1:4], up, down, axis=0, padtype="line")
    tg = np.arange(gyr.shape[0]) / (102.4 * up / down) + phase
    sections = str(DATA / "example_ferraris_session_list.json")
    if add is not None:
        name, axis, rate, n = add
        k = int(np.searchsorted(tg, t[json.loads(Path(sections).read_text())[name]["start"]] + 1.5))
        gyr[k : k + n, axis] += rate
    acc_file, gyro_file = tmp_path / "acc.csv", tmp_path / "gyro.csv"
    np.savetxt(acc_file, np.column_stack([t, rows[:, 4:7]]), delimiter=",", header="t,ax,ay,az", comments="")
    np.savetxt(gyro_file, np.column_stack([tg, gyr]), delimiter=",", header="t,gx,gy,gz", comments="")
    flags = ["--gyro-unit", "deg/s", "--gravity", "9.81", "--method", "ferraris", "--sections", sections]
    return [str(acc_file), "--gyro", str(gyro_file), *flags]


@pytest.fixture(scope="module")
def one_file_ferraris(tmp_path_factory):
    """The example recording's Ferraris calibration from its one file (imucal's values)."""
    sections = ["--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]
    return _run(tmp_path_factory.mktemp("one_file"), EXAMPLE + sections)


@pytest.mark.parametrize("up, down, phase", [(1, 2, 0.0), (9, 10, 0.0013)])
def test_ferraris_gyro_file_on_its_own_clock_is_the_one_file_result(tmp_path, one_file_ferraris, up, down, phase):
    """The example recording's gyroscope as a second file on its own clock, interpolated onto the accelerometer's times.
    At half the rate, every other row on a gyro sample (acc 200 Hz beside gyro 100 Hz), each row between was the
    line through its neighbours, and a real jerk of x_rot stood '18997× the departures around it': refused as a
    glitch, exit 2. At 0.9× the rows' sum of the interpolated rates gave K_zz 0.052 off (5.7 std of the one-file
    result), and the turns between the poses on the rows widened the std 5× (0.045). Both are judged on the
    gyroscope's own samples now: the one file's scales within 0.3 of its std, the std within 10 % of it."""
    r = _run(tmp_path, ["calibrate", "accel", *_gyro_on_its_own_clock(tmp_path, up, down, phase)])
    one = one_file_ferraris.gyroscope
    std, std1 = np.diag(np.asarray(r.gyroscope["K_std"])), np.diag(np.asarray(one["K_std"]))
    dev = np.abs(np.diag(r.gyroscope["K"]) - np.diag(one["K"]))
    assert np.all(dev < 0.5 * std1), (dev, std1)
    np.testing.assert_allclose(std, std1, rtol=0.1)


@pytest.mark.parametrize("samples, code", [(1, 0), (2, 2)])
def test_a_glitch_in_a_gyro_file_on_its_own_clock_is_judged_on_its_samples(tmp_path, capsys, samples, code):
    """300 °/s added to one sample of the 0.9× gyro file 1.5 s into y_rot: interpolated onto the accelerometer's
    rows it spread over two, unseen (K_yy 0.50 off, 18 std, exit 0); 150 °/s on two samples alike. On the file's
    own samples the spike is repaired (imucal's K_yy within 0.04 std) and the two-sample dropout refused."""
    rate = 300.0 if samples == 1 else 150.0
    args = _gyro_on_its_own_clock(tmp_path, 9, 10, 0.0013, add=("y_rot", 1, rate, samples))
    r = _run(tmp_path, ["calibrate", "accel", *args], code=code)
    err = capsys.readouterr().err
    if code:
        assert f"{samples} gyro y sample(s)" in err and "a dropout or glitch" in err, err
        return
    assert "1 gyro y sample(s)" in err and "a spike, replaced by its neighbours' mean" in err, err
    ref = read_imucal_json(DATA / "reference" / "example_ferraris_session_cal_102p4Hz.json").to_optinav()
    std = np.asarray(r.gyroscope["K_std"])[1, 1]
    assert abs(r.gyroscope["K"][1][1] - ref["gyr_K"][1][1]) < 0.5 * std


def test_default_route_judges_a_gyro_file_on_its_own_clock_on_its_samples(tmp_path):
    """The default route leaves out a turn whose gyro holds a glitch. The example recording's gyroscope at half the
    rate, every other accelerometer row on a gyro sample: the rows between were lines through their neighbours, and
    8 of the 9 turns between the rests held a real jerk 'far beyond the departures around it': left out, and the
    calibration refused ('1 transition(s) usable'). On the gyroscope's own samples none is: the one file's gyro
    scales within 0.3 of their std."""
    args = _gyro_on_its_own_clock(tmp_path, 1, 2, 0.0)
    default = args[: args.index("--method")]
    r = _run(tmp_path, ["calibrate", "accel", *default])
    one = _run(tmp_path, [*EXAMPLE])
    std = np.diag(np.asarray(one.gyroscope["K_std"], float))
    dev = np.abs(np.diag(r.gyroscope["K"]) - np.diag(one.gyroscope["K"]))
    assert np.all(dev < 0.3 * std), (dev, std)


@pytest.mark.parametrize("how, q, phase", [("rows", 2, 0), ("rows", 2, 1), ("decimate", 2, 0), ("rows", 4, 1)])
def test_a_ferraris_log_decimated_without_a_filter_is_in_its_std(tmp_path, capsys, one_file_ferraris, how, q, phase):
    """imucal's session with every q-th row kept, or low-passed first (scipy.signal.decimate). Kept rows fold what
    the hand turns held at the new rate into their integrals: at 51.2 Hz K_g 4.1, 3.7 and 4.9 std off the 102.4 Hz
    result with exit 0 (either phase; the std unchanged), at 25.6 Hz (phase 1) 31, 49 and 18 std. The gyro's noise at
    rest, white up to the new Nyquist frequency, shows no anti-alias filter, and the turns' content near it, carried
    to the sample rate at the slowest decay a turn can have (1/f), gives the error: at 51.2 Hz K_g within 0.14 of its
    std (30-64x the 102.4 Hz one), at 25.6 Hz within 0.27 (±3.4 % of each turn; it was refused as spectra not falling
    off). Low-passed first, the noise rolls off and the std and K stay (within 0.4 std, the std within 10 %)."""
    from scipy.signal import decimate

    rows = np.loadtxt(DATA / "example_ferraris_session.csv", delimiter=",", skiprows=1)[:, 1:]
    part = rows[phase::q] if how == "rows" else decimate(rows, q, ftype="fir", axis=0, zero_phase=True)
    f = tmp_path / "part.csv"
    np.savetxt(f, part, delimiter=",", header="gx,gy,gz,ax,ay,az", comments="", fmt="%.10g")
    sec = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    (tmp_path / "s.json").write_text(
        json.dumps({k: {e: (i - phase + q - 1) // q for e, i in v.items()} for k, v in sec.items()})
    )
    args = [*EXAMPLE, "--method", "ferraris", "--sections", str(tmp_path / "s.json")]
    args[2], args[4] = str(f), f"{102.4 / q:g}"
    r = _run(tmp_path, args)
    err = capsys.readouterr().err
    dev, std, std1 = _gyro_scales_against(r, one_file_ferraris)
    if how == "rows":
        assert np.all(dev < 0.5 * std) and np.all(std < (100 if q == 2 else 400) * std1), (dev / std, std / std1)
        assert "no anti-alias filter" in err and "K_g's std includes" in err
    else:
        assert np.all(dev < 0.5 * std) and np.allclose(std, std1, rtol=0.1), (dev / std, std / std1)
        assert "anti-alias" not in err


def _gyro_scales_against(r, one) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(|K_g diagonal − ``one``'s|, the diagonal's std, ``one``'s std) (3,) each, of the result ``r``."""
    std1 = np.diag(np.asarray(one.gyroscope["K_std"], float))
    std = np.diag(np.asarray(r.gyroscope["K_std"], float))
    return np.abs(np.diag(r.gyroscope["K"]) - np.diag(one.gyroscope["K"])), std, std1


def _gyro_file_ferraris(tmp_path, rows, tg, gyr, one_file) -> np.ndarray:
    """The Ferraris gyro scales' deviations (3,) from the ``one_file`` result, in their own std, of imucal's session
    ``rows`` given as two files: its accelerometer at 102.4 Hz and the gyroscope samples ``gyr`` (M, 3) deg/s at
    the times ``tg`` (M,) s."""
    t = np.arange(rows.shape[0]) / 102.4
    acc_file, gyro_file = tmp_path / "acc.csv", tmp_path / "gyro.csv"
    np.savetxt(acc_file, np.column_stack([t, rows[:, 4:7]]), delimiter=",", header="t,ax,ay,az", comments="")
    np.savetxt(gyro_file, np.column_stack([tg, gyr]), delimiter=",", header="t,gx,gy,gz", comments="")
    args = ["calibrate", "accel", str(acc_file), "--gyro", str(gyro_file), "--gyro-unit", "deg/s", "--gravity", "9.81"]
    r = _run(tmp_path, [*args, *FERRARIS])
    std = np.diag(np.asarray(r.gyroscope["K_std"], float))
    return (np.diag(r.gyroscope["K"]) - np.diag(one_file.gyroscope["K"])) / std


def test_a_gyro_file_of_every_other_sample_on_its_own_clock_is_in_its_std(tmp_path, capsys, one_file_ferraris):
    """imucal's session as two files, the gyroscope's every other sample on its own clock (51.2 Hz, no filter) beside
    the accelerometer at 102.4 Hz: K_g 4.2, 3.8 and 4.9 std off with exit 0, as in one file. The turn sampling is
    judged on the gyroscope's own samples, as in one file: within 0.4 of the std."""
    rows = np.loadtxt(DATA / "example_ferraris_session.csv", delimiter=",", skiprows=1)
    t = np.arange(rows.shape[0]) / 102.4
    z = _gyro_file_ferraris(tmp_path, rows, t[::2], rows[::2, 1:4], one_file_ferraris)
    assert "Nyquist frequency (25.6 Hz: no anti-alias filter)" in capsys.readouterr().err
    assert np.all(np.abs(z) < 0.5), z


def test_a_gyro_file_interpolated_from_the_accelerometers_clock_is_in_its_std(tmp_path, capsys, one_file_ferraris):
    """imucal's gyroscope linearly interpolated onto 0.8x the accelerometer's rate (a second file on its own clock):
    the interpolant's kinks put an image of the turns' content at 20.5 Hz at the file's rate, which its samples fold
    into the turn integrals: K_yy 4.0 std off the one file's with exit 0. The file's noise at rest varies with its
    samples' phase on the accelerometer's clock as a linear interpolation's does (7 std of that regression), so the
    image's bound enters K_g's std: every scale within 1.5 std (1.15), and a note says why."""
    rows = np.loadtxt(DATA / "example_ferraris_session.csv", delimiter=",", skiprows=1)
    t = np.arange(rows.shape[0]) / 102.4
    tg = np.arange(0.0, t[-1], 1.0 / (0.8 * 102.4)) + 0.0013
    gyr = np.column_stack([np.interp(tg, t, rows[:, 1 + j]) for j in range(3)])
    z = _gyro_file_ferraris(tmp_path, rows, tg, gyr, one_file_ferraris)
    assert "its samples were interpolated from samples on that clock" in capsys.readouterr().err
    assert np.all(np.abs(z) < 1.5), z


@pytest.fixture(scope="module")
def one_file_default(tmp_path_factory):
    """The example recording's default-route calibration from its one file."""
    return _run(tmp_path_factory.mktemp("one_file_default"), [*EXAMPLE])


def test_default_route_integrates_the_turns_on_a_gyro_files_own_samples(tmp_path, one_file_default):
    """The example recording's gyroscope as a second file at 0.9x the rate (band-limited, its own clock): the
    default route's turns were integrated over the gyro interpolated onto the accelerometer's rows, whose kinks at a
    hand turn's jerks moved K_yy 0.64 of its std off the one file's (0.9x: 0.64; 1.3x: 0.29). On the file's own
    samples every gyro scale is within 0.2 of its std (0.02)."""
    args = _gyro_on_its_own_clock(tmp_path, 9, 10, 0.0013)
    r = _run(tmp_path, ["calibrate", "accel", *args[: args.index("--method")]])
    one = one_file_default.gyroscope
    std = np.diag(np.asarray(one["K_std"], float))
    dev = np.abs(np.diag(r.gyroscope["K"]) - np.diag(one["K"]))
    assert np.all(dev < 0.2 * std), dev / std


def test_a_gyro_file_with_every_sample_written_twice_is_refused_as_duplicates(tmp_path, capsys):
    """imucal's example recording with its gyroscope file (0.9x, its own clock) holding every sample twice (a
    logger that writes each sample twice): the check of each file's clock divided by its median step, 0, and the
    command ended in an internal error (ZeroDivisionError, exit 1). It is refused as the duplicates it holds."""
    args = _gyro_on_its_own_clock(tmp_path, 9, 10, 0.0013)
    gyro_file = Path(args[2])
    rows = np.loadtxt(gyro_file, delimiter=",", skiprows=1)
    np.savetxt(gyro_file, np.repeat(rows, 2, axis=0), delimiter=",", header="t,gx,gy,gz", comments="")
    _run(tmp_path, ["calibrate", "accel", *args], code=2)
    err = capsys.readouterr().err
    assert "has a duplicate timestamp" in err and "gyro.csv" in err, err


@pytest.mark.parametrize("how, phase", [("rows", 0), ("rows", 3), ("decimate", 0)])
def test_default_route_on_a_log_decimated_without_a_filter_is_in_its_std(
    tmp_path, capsys, one_file_default, how, phase
):
    """imucal's session on every 4th row (25.6 Hz, no filter) by the default route: the turns fold what they held at
    the new rate into their integrals, K_yy 2.55 (phase 0) and 1.92 (phase 3) std off the 102.4 Hz result with
    exit 0. The rests' noise shows no anti-alias filter, and the turns' sampling term (as the Ferraris route's)
    enters K's std: within 0.8 of it (0.77, 0.51), with a note. Low-passed first (scipy.signal.decimate) the std
    stays the full rate's (1.01x) and K within 0.4 of it."""
    from scipy.signal import decimate

    rows = np.loadtxt(DATA / "example_ferraris_session.csv", delimiter=",", skiprows=1)[:, 1:]
    part = rows[phase::4] if how == "rows" else decimate(rows, 4, ftype="fir", axis=0, zero_phase=True)
    f = tmp_path / "part.csv"
    np.savetxt(f, part, delimiter=",", header="gx,gy,gz,ax,ay,az", comments="", fmt="%.10g")
    args = list(EXAMPLE)
    args[2], args[4] = str(f), "25.6"
    r = _run(tmp_path, args)
    err = capsys.readouterr().err
    dev, std, std1 = _gyro_scales_against(r, one_file_default)
    if how == "rows":
        assert np.all(dev < 0.8 * std) and np.all(std < 40 * std1), (dev / std, std / std1)
        assert "no anti-alias filter" in err and "K_g's std includes" in err
    else:
        assert np.all(dev < 0.4 * std) and np.allclose(std, std1, rtol=0.05), (dev / std, std / std1)
        assert "anti-alias" not in err


def test_a_st_style_log_in_mg_and_mdps_calibrates_and_applies_like_the_si_one(tmp_path, capsys):
    """ST's MEMS drivers log mg and mdps (millidegrees per second); a gyro in mdps had no unit to declare (its
    header's [mdps] was refused, and no --gyro-unit took it). imucal's session rewritten in mg and mdps (its column
    names carrying the units): the same calibration, K in mg and mdps per SI unit (×1000/g and ×1000 of the
    m/s^2 and deg/s file's), and `apply` gives the same corrected samples to the rounding of the rewrite."""
    raw = np.genfromtxt(DATA / "example_ferraris_session.csv", delimiter=",", names=True)
    st = tmp_path / "st.csv"
    head = "n,gyr_x [mdps],gyr_y [mdps],gyr_z [mdps],acc_x [mg],acc_y [mg],acc_z [mg]"
    gyr = np.column_stack([raw[f"gyr_{a}"] for a in "xyz"]) * 1000.0
    acc = np.column_stack([raw[f"acc_{a}"] for a in "xyz"]) / 9.80665 * 1000.0
    np.savetxt(st, np.column_stack([raw["n_samples"], gyr, acc]), delimiter=",", header=head, comments="", fmt="%.17g")
    ours = _run(tmp_path, ["calibrate", "accel", str(st), "--rate", "102.4", "--gravity", "9.81"])
    assert ours.units["gyroscope_raw"] == "mdps" and ours.units["accelerometer_raw"] == "mg"
    ref = _run(tmp_path, EXAMPLE)
    # the fits stop at their tolerance in units 1000× apart: alike to 1e-7 of the scale
    k_g, k_a = ref.gyroscope["K"] * 1000.0, ref.accelerometer["K"] * 1000.0 / 9.80665
    np.testing.assert_allclose(ours.gyroscope["K"], k_g, rtol=0, atol=1e-7 * np.abs(k_g).max())
    np.testing.assert_allclose(ours.accelerometer["K"], k_a, rtol=0, atol=1e-7 * np.abs(k_a).max())
    np.testing.assert_allclose(ours.gyroscope["b"], ref.gyroscope["b"] * 1000.0, rtol=0, atol=1e-7 * 1000.0)
    capsys.readouterr()
    for res, data, extra, out in (
        (ours, st, [], "a.csv"),
        (ref, DATA / "example_ferraris_session.csv", ["--gyro-unit", "deg/s"], "b.csv"),
    ):
        res.to_json(tmp_path / f"{out}.json")
        argv = ["--quiet", "apply", str(tmp_path / f"{out}.json"), str(data), "--rate", "102.4", *extra]
        assert main([*argv, "--out", str(tmp_path / out)]) == 0
    from optinav.io import read_imu

    a, b = read_imu(tmp_path / "a.csv"), read_imu(tmp_path / "b.csv")
    np.testing.assert_allclose(a.acc, b.acc, atol=1e-6)  # m/s^2
    np.testing.assert_allclose(a.gyr, b.gyr, atol=1e-7)  # rad/s
    # declared by the flag instead of the header, and named in the unit check when the header is dropped
    bare = tmp_path / "bare.csv"
    bare.write_text("\n".join(["n,gx,gy,gz,ax,ay,az", *st.read_text().splitlines()[1:]]) + "\n")
    cal = ["calibrate", "accel", str(bare), "--rate", "102.4", "--gravity", "9.81", "--acc-unit", "mg"]
    same = _run(tmp_path, [*cal, "--gyro-unit", "mdps"])
    np.testing.assert_array_equal(same.gyroscope["K"], ours.gyroscope["K"])
    assert main([*cal, "--gyro-unit", "deg/s", "--out", str(tmp_path / "x.json")]) == 2
    assert "the data look like mdps" in capsys.readouterr().err


def test_raw_counts_for_attitude_are_named_counts_not_deg_s(tmp_path, capsys):
    """imucal's annotated session (raw counts, gyro peaks at 8877) for `optinav attitude` with only --rate was told
    "it looks like deg/s declared rad/s; --gyro-unit deg/s", and then, with that flag, that it was beyond any range:
    8877 read as deg/s is beyond any gyro too, so the first message names counts (or mdps) and the accelerometer."""
    argv = ["attitude", str(DATA / "annotated_session.csv"), "--rate", "204.8", "--out", str(tmp_path / "a.csv")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--gyro-unit deg/s" not in err and "(8877 in the file)" in err and "raw counts?" in err
    assert "accelerometer's median norm 2060 is not g either" in err and "optinav calibrate accel" in err


def test_attitude_of_raw_counts_by_their_datasheet_sensitivity(tmp_path, capsys):
    """The annotated session's raw counts for `optinav attitude` with --acc-lsb 2048 --gyro-lsb 16.4 (the
    nominal sensitivities of its ±16 g / ±2000 °/s ranges): the attitude of the same samples converted to m/s^2 and
    rad/s by those numbers beforehand, to the bit, with a note that no calibration was applied."""
    raw = np.genfromtxt(DATA / "annotated_session.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    si = tmp_path / "si.csv"
    acc = np.column_stack([raw[f"acc_{a}"] for a in "xyz"]).astype(float) * (9.80665 / 2048)
    gyr = np.column_stack([raw[f"gyr_{a}"] for a in "xyz"]).astype(float) * (DEG / 16.4)
    np.savetxt(si, np.column_stack([acc, gyr]), delimiter=",", header="ax,ay,az,gx,gy,gz", comments="", fmt="%.17g")
    from optinav.io.readers import read_table

    q = []
    for data, extra in (
        (DATA / "annotated_session.csv", ["--acc-lsb", "2048", "--gyro-lsb", "16.4"]),
        (si, []),
    ):
        out = tmp_path / f"{len(extra)}.csv"
        assert main(["attitude", str(data), "--rate", "204.8", *extra, "--out", str(out)]) == 0
        tab = read_table(out)
        q.append(np.column_stack([tab[k] for k in ("qw", "qx", "qy", "qz")]))
    assert "accelerometer counts read as m/s^2 by 2048 per g (a nominal sensitivity, no calibration)" in (
        capsys.readouterr().err
    )
    np.testing.assert_array_equal(q[0], q[1])


def test_a_continuous_session_with_its_sections_labelled_keeps_the_default_lm(tmp_path, capsys):
    """imucal's continuous session with its nine sections written into a label column (from its section list; the
    rows between them unlabelled): the turns between the poses are in the file, so the default stays lm (only a log
    cut to the sections takes ferraris); --method ferraris reads the sections from the labels as from the list."""
    raw = (DATA / "example_ferraris_session.csv").read_text().splitlines()
    sections = json.loads((DATA / "example_ferraris_session_list.json").read_text())
    label = [""] * (len(raw) - 1)
    for name, rng in sections.items():
        a, b = (rng["start"], rng["end"]) if isinstance(rng, dict) else rng
        label[int(a) : int(b)] = [name] * (int(b) - int(a))
    path = tmp_path / "labelled.csv"
    path.write_text("\n".join([raw[0] + ",part", *(f"{r},{lab}" for r, lab in zip(raw[1:], label))]) + "\n")
    args = [a if a != str(DATA / "example_ferraris_session.csv") else str(path) for a in EXAMPLE]
    assert _run(tmp_path, args).method == "lm"
    named = _run(tmp_path, [*args, "--method", "ferraris"])
    listed = _run(
        tmp_path, [*EXAMPLE, "--method", "ferraris", "--sections", str(DATA / "example_ferraris_session_list.json")]
    )
    np.testing.assert_array_equal(named.accelerometer["K"], listed.accelerometer["K"])
    np.testing.assert_array_equal(named.gyroscope["K"], listed.gyroscope["K"])


def test_attitude_of_raw_counts_by_a_wrong_sensitivity_names_it(tmp_path, capsys):
    """A gyro sensitivity 100× too small (0.164 for the annotated session's 16.4: its peak beyond any gyro) ended
    in "unknown unit 'counts'"; given per rad/s (940 for 16.4 per deg/s) on a BROAD trial written in counts (gravity
    turns in the body: the turns 57× short of gravity's) it named --gyro-unit. Both errors name --gyro-lsb. (On the
    annotated session the turns are about the vertical, which the accelerometer does not see: no check can tell.)"""
    argv = ["--quiet", "attitude", str(DATA / "annotated_session.csv"), "--rate", "204.8", "--acc-lsb", "2048"]
    assert main([*argv, "--gyro-lsb", "0.164", "--out", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "check --gyro-lsb: counts per deg/s" in err and "unknown unit" not in err, err
    broad = DATA.parent / "attitude" / "broad" / "02_undisturbed_slow_rotation_B.hdf5"
    if not broad.is_file():
        pytest.skip("BROAD data absent")
    from optinav.attitude.data import load_broad

    tr, n = load_broad(broad), 20000
    raw = tmp_path / "b02.csv"
    np.savetxt(raw, np.column_stack([np.arange(n) * tr.dt, np.round(tr.acc[:n] / 9.80665 * 2048),
                                     np.round(np.degrees(tr.gyr[:n]) * 16.4)]),
               delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="", fmt=["%.6f"] + ["%d"] * 6)  # fmt: skip
    argv = ["--quiet", "attitude", str(raw), "--frame", "ENU", "--acc-lsb", "2048", "--out", str(tmp_path / "b.csv")]
    assert main([*argv, "--gyro-lsb", "940"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the gyro turns gravity ×0.0" in err and "check --gyro-lsb" in err, err
    assert main([*argv, "--gyro-lsb", "16.4"]) == 0


def test_a_swarm_that_stopped_short_of_its_minimum_says_so_and_its_std_covers_it(tmp_path, capsys):
    """The accelerometer by PSO at 3, 10 and its default 150 generations: the swarm stopped 1.3–1.5 noise std short
    of the minimum of its own objective (unweighted pose means, the one Newton's method minimizes here), with
    "converged" and exit 0, its parameters up to 1.5 std from LM's. The shortfall, which the swarm's spread does
    not show, is measured by a local search from its best (x + shortfall is Newton's minimum) and added to the
    std; the convergence message says how far it stopped."""

    def fit(*args):
        r = _run(tmp_path, EXAMPLE + list(args))
        a = r.accelerometer
        theta = np.r_[np.diag(a["K"]), a["b"]]
        return theta, np.r_[np.diag(a["K_std"]), a["b_std"]], r.convergence["message"]

    lm, newton = fit("--method", "lm")[0], fit("--method", "newton")[0]
    for g in ("3", "10", "150"):
        theta, std, message = fit("--method", "pso", "--generations", g)
        assert "std short of its objective's minimum on" in message and "(added to the std)" in message
        assert "note: the PSO search stopped" in capsys.readouterr().err
        # Newton's minimum differs from the swarm's by its shortfall, which the std now holds
        assert np.all(np.abs(newton - theta) <= std * (1 + 1e-6)), (g, np.abs(newton - theta) / std)
        assert np.all(np.abs(lm - theta) < std), (g, np.abs(lm - theta) / std)
