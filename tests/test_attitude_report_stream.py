"""`optinav attitude --report` estimates block by block (issue 17): its summary is the in-memory estimate's and its
figure every k-th row of the written attitude, so the report is bounded in memory."""

import json

import numpy as np
import pytest

from optinav.attitude import PolarizationMeasurement, estimate
from optinav.attitude.filestream import pol_columns, stream_attitude
from optinav.attitude.recording import attitude_rows, sun_along_log
from optinav.attitude.unit import AttitudeOptions
from optinav.cli.main import main
from optinav.reports.attitude_report import attitude_tables


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    from optinav.attitude.simulate import PAPER_SITE, PAPER_TIMES, simulate

    d = simulate("dynamic", duration_s=12, rate_hz=100, rng=7, gyro_bias=np.radians([0.3, -0.2, 0.25]))
    path = tmp_path_factory.mktemp("rep") / "flight.csv"
    cols = np.column_stack([d.t, d.acc, d.gyr, d.aop, d.dop])
    np.savetxt(path, cols, delimiter=",", header="t,ax,ay,az,gx,gy,gz,aop,dop", comments="", fmt="%.17g")
    sun = dict(lat=PAPER_SITE["lat"], lon=PAPER_SITE["lon"], height_m=35.0, start_time=PAPER_TIMES["dynamic"])
    return d, path, sun


def _values(tables):
    return [[getattr(c, "value", c) for c in row] for t in tables for row in t.rows]


@pytest.mark.parametrize(
    "method, offline, pol",
    [
        ("iframe", False, False),
        ("iframe", True, False),
        ("qn", False, False),
        ("mekf", False, True),
        ("iframe", True, True),
    ],
)
def test_streamed_report_fields_are_the_in_memory_estimates(flight, tmp_path, method, offline, pol):
    d, path, sun = flight
    o = AttitudeOptions(method=method, frame="NED", offline=offline)
    pc = pol_columns("aop,dop", "NED", **sun) if pol else None
    run = stream_attitude(path, tmp_path / "a.csv", o, pol=pc, chunk_rows=333, figure_points=150)
    dt = np.r_[d.t[1] - d.t[0], np.diff(d.t)]
    pm = PolarizationMeasurement(d.aop, sun_along_log(d.t, "NED", **sun), dop=d.dop, frame="NED") if pol else None
    res = estimate(d.gyr, d.acc, dt, pol=pm, method=method, frame="NED", offline=offline)
    assert run.estimate.summary() == res.summary()
    got, want = _values(attitude_tables(run.estimate, run.n)), _values(attitude_tables(res, d.t.size))
    # the heading branch's AoP residuals (polarization without q0): to the rounding of a block's sun vector
    branch = [i for i, row in enumerate(want) if row[0].startswith("heading branch")]
    for i in branch:
        assert got[i][0] == want[i][0] and np.allclose(got[i][1], want[i][1], rtol=1e-9, atol=0)
        got[i] = want[i]
    assert bool(branch) == pol
    assert got[:-1] == want[:-1] if res.gyr_bias is not None else got == want
    if res.gyr_bias is not None:  # the final gyro bias, to the rounding of the blocks' arithmetic
        assert np.allclose(got[-1][1], want[-1][1], rtol=0, atol=1e-12)
    if pol:
        assert run.estimate.pol_used > 0 and run.estimate.pol_used == res.pol_used
    # the figure: every k-th row of the written attitude (k = ceil(n / 150))
    rows = attitude_rows(d.t, res.q_b_n, "NED")
    k = -(-d.t.size // 150)
    t, eul = run.figure
    assert np.array_equal(t, rows[::k, 0]) and np.allclose(eul, rows[::k, 5:8], rtol=0, atol=1e-9)


def test_cli_report_streams(flight, tmp_path):
    _, path, _ = flight
    rep = tmp_path / "rep"
    argv = ["--quiet", "attitude", str(path), "--out", str(tmp_path / "a.csv"), "--report", str(rep), "--chunk-rows"]
    assert main([*argv, "500"]) == 0
    study = json.loads((rep / "summary.json").read_text())["studies"]["attitude"]
    rows = {r[0]: r[1] for t in study["tables"] for r in t["rows"]}
    assert rows["samples"] == 1201 and rows["method"] == "iframe"  # 12 s at 100 Hz, both ends
    assert (rep / "attitude_euler.png").is_file()


def test_the_euler_figure_of_a_log_timed_since_the_epoch_starts_at_its_first_sample(tmp_path, monkeypatch):
    """A time column since the epoch (1.7e9 s) drew an axis labelled "+1.7e9" whose ticks all read the same:
    the figure's time now runs from the log's first sample, which the axis label states."""
    from matplotlib.figure import Figure as MplFigure

    from optinav.attitude import estimate
    from optinav.reports import attitude_report

    captured = []
    monkeypatch.setattr(attitude_report, "write_report", lambda studies, *a, **k: captured.extend(studies))
    t = 1_700_000_123.5 + np.arange(500) * 0.01
    gyr, acc = np.zeros((500, 3)), np.tile([0.0, 0.0, 9.81], (500, 1))
    res = estimate(gyr, acc, 0.01, frame="ENU")
    attitude_report.write_attitude_report(res, t, np.zeros((500, 3)), "log.csv", tmp_path)
    fig = MplFigure()
    captured[0].figures[0].draw(fig)
    ax = fig.axes[-1]
    x = ax.lines[0].get_xdata()
    assert x[0] == 0.0 and abs(x[-1] - 4.99) < 1e-6  # (1.7e9 + 4.99 s holds 0.2 µs in a float64)
    assert ax.get_xlabel() == "t − 1700000123.500 s [s]"


def test_the_summary_says_how_much_of_the_magnetometer_was_used(tmp_path):
    """With a magnetometer the report's summary had no line on it; it now gives the share of samples
    whose field was used, in memory and streamed alike, and none without one."""
    from optinav.reports.attitude_report import attitude_tables

    n = 400
    gyr, acc = np.zeros((n, 3)), np.tile([0.0, 0.0, 9.81], (n, 1))
    mag = np.tile([20.0, 0.0, -40.0], (n, 1))
    mag[::2] = np.nan  # a magnetometer at half the rate
    res = estimate(gyr, acc, 0.01, frame="ENU", mag=mag)
    rows = {r[0]: r[1] for r in attitude_tables(res, n)[0].rows}
    # of the magnetometer's own samples (it said 50 % at most, as if half the field had been rejected)
    share = 100.0 * np.count_nonzero(res.mag_used) / (n // 2)
    assert 50.0 < share <= 100.0 and rows["magnetometer samples used [%]"].value == pytest.approx(share)
    assert res.mag_rows == n // 2 and f"magnetometer used {share:.0f} % of its {n // 2} samples" in res.summary()
    csv = tmp_path / "half.csv"
    t = np.arange(n) * 0.01
    np.savetxt(csv, np.column_stack([t, gyr, acc, mag]), delimiter=",", header="t,gx,gy,gz,ax,ay,az,mx,my,mz")
    for extra in ([], ["--offline"]):
        from optinav.attitude.filestream import stream_attitude
        from optinav.attitude.unit import AttitudeOptions

        run = stream_attitude(csv, tmp_path / "o.csv", AttitudeOptions(frame="ENU", mag=True, offline=bool(extra)))
        want = estimate(gyr, acc, 0.01, frame="ENU", mag=mag, offline=bool(extra))
        assert run.estimate.mag_rows == n // 2 and run.summary == want.summary(), (run.summary, want.summary())
    rows = {r[0]: r[1] for r in attitude_tables(estimate(gyr, acc, 0.01, frame="ENU"), n)[0].rows}
    assert "magnetometer samples used [%]" not in rows


def test_the_euler_figure_draws_no_line_across_the_wrap(tmp_path, monkeypatch):
    """A turn at 90 °/s for 20 s wraps the yaw at ±180° five times: the figure drew a vertical line across the
    panel at each wrap (BROAD trial 02's roll and yaw panels were full of them). Now the line breaks there:
    no two consecutive points drawn are more than 180° apart, and every sample is still drawn but the wraps."""
    from matplotlib.figure import Figure as MplFigure

    from optinav.reports import attitude_report

    captured = []
    monkeypatch.setattr(attitude_report, "write_report", lambda studies, *a, **k: captured.extend(studies))
    n, dt = 2000, 0.01
    gyr, acc = np.tile([0.0, 0.0, np.pi / 2], (n, 1)), np.tile([0.0, 0.0, 9.81], (n, 1))
    res = estimate(gyr, acc, dt, frame="ENU")
    eul = np.degrees(res.euler())
    assert np.count_nonzero(np.abs(np.diff(eul[:, 2])) > 180.0) == 5  # the wraps the test is about
    attitude_report.write_attitude_report(res, np.arange(n) * dt, eul, "log.csv", tmp_path)
    fig = MplFigure()
    captured[0].figures[0].draw(fig)
    y = np.asarray(fig.axes[2].lines[0].get_ydata(), float)
    drawn = np.isfinite(y[1:]) & np.isfinite(y[:-1])
    assert np.all(np.abs(np.diff(y))[drawn] <= 180.0)
    assert np.count_nonzero(~np.isfinite(y)) == 5


@pytest.mark.parametrize("method", ["gd", "mekf"])
def test_the_summary_names_the_input_stage(flight, tmp_path, method):
    """gd/cg/qn/mekf with and without --input-stage gave the same summary line and report title ("gd: 1201
    samples (ned)"; methods compared on BROAD: 0.597° against 0.314° under one label); the line now says
    it, in memory and streamed alike, and iframe (whose front end is always on) does not."""
    d, path, _ = flight
    dt = np.r_[d.t[1] - d.t[0], np.diff(d.t)]
    for stage in (False, True):
        res = estimate(d.gyr, d.acc, dt, method=method, input_stage=stage)
        o = AttitudeOptions(method=method, input_stage=stage)
        run = stream_attitude(path, tmp_path / "a.csv", o, chunk_rows=500)
        assert run.estimate.summary() == res.summary()
        assert ("input stage" in res.summary()) == stage, res.summary()
    assert "input stage" not in estimate(d.gyr, d.acc, dt).summary()


def test_the_report_table_and_title_name_the_variant(flight, tmp_path):
    """The report's summary table and title read "method qn" for qn as published and behind the input stage alike
    (BROAD 02: 0.687° / 0.400° inclination under one label in summary.json); both now name the variant, and so does
    the summary line of the published one (the default is the input stage since 21408c0)."""
    _, path, _ = flight
    seen = {}
    for flag in ("--input-stage", "--no-input-stage"):
        rep = tmp_path / flag
        argv = ["--quiet", "attitude", str(path), "--method", "qn", flag, "--out", str(tmp_path / "a.csv")]
        assert main([*argv, "--report", str(rep)]) == 0
        st = json.loads((rep / "summary.json").read_text())["studies"]["attitude"]
        rows = dict(map(tuple, st["tables"][0]["rows"]))
        seen[flag] = (st["title"], rows["method"], rows["input stage"])
    assert seen["--input-stage"] == (
        "Attitude of flight.csv (qn with the input stage)",
        "qn with the input stage",
        "on",
    )
    assert seen["--no-input-stage"] == (
        "Attitude of flight.csv (qn as published)",
        "qn as published",
        "off (as published)",
    )


def test_the_report_gives_the_estimates_time_not_zero(flight, tmp_path):
    """The attitude report read "_Study `attitude`, 0.0 s._" whatever the estimate took (4 s on BROAD 02):
    a result's report gives the result's elapsed_s, a streamed run (which keeps no time) none."""
    from optinav.attitude.unit import read_log, steps

    d, path, _ = flight
    rep = tmp_path / "rep"
    assert main(["--quiet", "attitude", str(path), "--out", str(tmp_path / "a.csv"), "--report", str(rep)]) == 0
    text = (rep / "index.md").read_text()
    assert "_Study `attitude`._" in text and " 0.0 s" not in text
    t, gyr, acc, _, _ = read_log(path, AttitudeOptions())
    res = estimate(gyr, acc, steps(t))
    res.elapsed_s = 2.25
    res.to_json(tmp_path / "r.json")
    assert (
        main(["--quiet", "report", str(tmp_path / "r.json"), "--data", str(path), "--out", str(tmp_path / "r2")]) == 0
    )
    assert "_Study `attitude`, 2.2 s._" in (tmp_path / "r2" / "index.md").read_text()


def test_the_report_summary_names_its_version(flight, tmp_path):
    """summary.json held a title and the studies but neither the optinav version nor when it was written (index.md
    a local time without zone), so two reports' numbers could not be told apart by the code that made them."""
    import optinav

    _, path, _ = flight
    rep = tmp_path / "rep"
    assert main(["--quiet", "attitude", str(path), "--out", str(tmp_path / "a.csv"), "--report", str(rep)]) == 0
    s = json.loads((rep / "summary.json").read_text())
    assert (s["schema"], s["version"], s["optinav_version"]) == ("optinav.report_summary", 1, optinav.__version__)
    assert s["written_utc"].endswith("Z") and s["written_utc"] in (rep / "index.md").read_text()
    assert f"by optinav {optinav.__version__}." in (rep / "index.md").read_text()
