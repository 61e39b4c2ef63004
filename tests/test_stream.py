"""Streamed reading, correcting and attitude (issue 17): the block-by-block path equals the whole-log path, and
the block size bounds what the reader hands out. Memory figures are in benchmarks/bench_memory.py."""

from __future__ import annotations

import gzip
import io
import os
import hashlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.io import ImuLog, read_imu, write_imu
from optinav.io.imu import iter_imu, open_imu_writer
from optinav.io.readers import iter_table, load_table

FIELDS = ("t", "acc", "gyr", "labels", "sample")


def _logger_file(path, rows: np.ndarray, *, truncated: bool = False, blank_at: int | None = None) -> None:
    """A logger-style CSV: a key,value preamble (rate), a comment, a header with units, blank and comment lines
    inside, optionally an incomplete last line."""
    lines = ["Fs,100", "device,test unit", "# exported by a logger", "ax [g],ay [g],az [g],gx [deg/s],gy,gz"]
    for i, r in enumerate(rows):
        lines.append(",".join(repr(float(v)) for v in r))
        if i == blank_at:
            lines += ["", "# a note in the middle"]
    text = "\n".join(lines) + "\n"
    if truncated:
        text += "0.5,0.25"
    path.write_bytes(gzip.compress(text.encode()) if str(path).endswith(".gz") else text.encode())


def _same(blocks, whole, chunk: int) -> None:
    assert blocks and all(0 < len(b) <= chunk for b in blocks)
    for name in FIELDS:
        w = getattr(whole, name)
        if w is None:
            assert all(getattr(b, name) is None for b in blocks)
        else:
            np.testing.assert_array_equal(np.concatenate([getattr(b, name) for b in blocks]), w)
    assert [n for b in blocks for n in b.notes] == whole.notes
    assert sum(b.nan_rows for b in blocks) == whole.nan_rows
    assert blocks[0].acc_input_unit == whole.acc_input_unit and blocks[0].gyro_input_unit == whole.gyro_input_unit


@pytest.mark.parametrize("name", ["log.csv", "log.csv.gz"])
@pytest.mark.parametrize("chunk", [1, 7, 64, 10_000])
def test_blocks_equal_whole_logger_file(tmp_path, name, chunk):
    rng = np.random.default_rng(3)
    rows = rng.normal(size=(301, 6))
    rows[40, 1] = np.nan  # a missing sample stays a NaN row
    p = tmp_path / name
    _logger_file(p, rows, truncated=True, blank_at=120)
    whole = read_imu(p)
    assert whole.acc_input_unit == "g" and whole.gyro_input_unit == "deg/s"
    assert any("incomplete" in n for n in whole.notes) and any("100 Hz" in n for n in whole.notes)
    _same(list(iter_imu(p, chunk_rows=chunk)), whole, chunk)
    # the raw table blocks: at most `chunk` rows each, numbered from the file's first data row
    tables = list(iter_table(p, chunk_rows=chunk))
    assert all(len(t.data["ax [g]"]) <= chunk for t in tables)
    assert [t.row0 for t in tables] == list(np.cumsum([0] + [len(t.data["ax [g]"]) for t in tables[:-1]]))
    assert tables[-1].meta == load_table(p).meta


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(2, 60),
    chunk=st.integers(1, 70),
    counts=st.booleans(),
    labels=st.booleans(),
    seed=st.integers(0, 2**16),
)
def test_blocks_equal_whole_written_logs(tmp_path_factory, n, chunk, counts, labels, seed):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.005, 0.02, n))
    acc = np.round(rng.normal(0, 2000, (n, 3))) if counts else rng.normal(0, 9.8, (n, 3))
    log = ImuLog(
        t=t,
        acc=acc,
        gyr=rng.normal(size=(n, 3)),
        acc_unit="counts" if counts else "m/s^2",
        labels=np.array(["rest", "pose"])[rng.integers(0, 2, n)] if labels else None,
        sample=np.arange(n) + 5,
    )
    p = tmp_path_factory.mktemp("w") / "log.tsv"
    write_imu(p, log)
    _same(list(iter_imu(p, chunk_rows=chunk)), read_imu(p), chunk)


def test_binary_formats_are_cut_into_blocks(tmp_path):
    rng = np.random.default_rng(4)
    log = ImuLog(t=np.arange(50) / 10.0, acc=rng.normal(size=(50, 3)), gyr=rng.normal(size=(50, 3)))
    p = tmp_path / "log.npz"
    write_imu(p, log)
    _same(list(iter_imu(p, chunk_rows=8)), read_imu(p), 8)


def test_bad_cell_names_its_line_and_column_in_any_block(tmp_path):
    rows = np.random.default_rng(5).normal(size=(500, 6))
    p = tmp_path / "log.csv"
    _logger_file(p, rows)
    lines = p.read_text().splitlines()
    cells = lines[450].split(",")
    cells[2] = "abc"
    lines[450] = ",".join(cells)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(OptinavError, match=r"log.csv line 451, column 3 \('az \[g\]'\): 'abc' is not a number") as e0:
        read_imu(p)
    for chunk in (7, 100_000):
        with pytest.raises(OptinavError) as e:
            list(iter_imu(p, chunk_rows=chunk))
        assert str(e.value) == str(e0.value)


def test_time_order_and_empty_columns_are_checked_across_blocks(tmp_path):
    p = tmp_path / "dup.csv"
    write_imu(p, ImuLog(t=np.arange(30) / 10.0, acc=np.ones((30, 3))))
    text = p.read_text().replace("\n2.0,", "\n1.9,", 1)  # row 20 repeats row 19: a duplicate at a block boundary
    p.write_text(text)
    with pytest.raises(OptinavError, match="duplicate timestamp at index 20") as e0:
        read_imu(p)
    with pytest.raises(OptinavError) as e:
        list(iter_imu(p, chunk_rows=20))
    assert str(e.value) == str(e0.value)
    # a column empty in one block is fine, empty in the whole file is the whole reader's error
    q = tmp_path / "empty.csv"
    q.write_text("t,ax,ay,az\n" + "".join(f"{i / 100},1,{'' if i < 25 else 2},3\n" for i in range(30)))
    assert len(sum((list(b.acc[:, 1]) for b in iter_imu(q, chunk_rows=10)), [])) == 30
    r = tmp_path / "none.csv"
    r.write_text("t,ax,ay,az\n" + "".join(f"{i / 100},1,,3\n" for i in range(30)))
    with pytest.raises(OptinavError) as e0:
        read_imu(r)
    with pytest.raises(OptinavError) as e:
        list(iter_imu(r, chunk_rows=10))
    assert str(e.value) == str(e0.value)


def test_writer_blocks_read_back_exactly(tmp_path):
    rng = np.random.default_rng(6)
    log = ImuLog(
        t=np.arange(100) / 50.0, acc=rng.normal(size=(100, 3)), gyr=rng.normal(size=(100, 3)), labels=np.arange(100) % 3
    )
    for name in ("w.csv", "w.npz"):
        with open_imu_writer(tmp_path / name, acc_unit="g") as w:
            for a in range(0, 100, 13):
                w.write(log.select(slice(a, a + 13)))
        back = read_imu(tmp_path / name)
        np.testing.assert_allclose(back.acc, log.acc, rtol=1e-15, atol=0)
        np.testing.assert_array_equal(back.gyr, log.gyr)
        np.testing.assert_array_equal(back.labels, log.labels)
    # an error inside the block leaves nothing under the final name
    with pytest.raises(OptinavError):
        with open_imu_writer(tmp_path / "x.csv") as w:
            w.write(log.select(slice(0, 10)))
            raise OptinavError("stop", "-")
    assert not (tmp_path / "x.csv").exists()


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("session")
    assert (
        main(
            [
                "--quiet",
                "simulate",
                "accel-multipos",
                "--out",
                str(d / "s.csv"),
                "--dwell",
                "6",
                "--rest",
                "10",
                "--seed",
                "2",
                "--acc-unit",
                "g",
                "--gyro-unit",
                "deg/s",
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "--quiet",
                "calibrate",
                "accel",
                str(d / "s.csv"),
                "--latitude",
                "38.88",
                "--height",
                "35",
                "--out",
                str(d / "r.json"),
            ]
        )
        == 0
    )
    return d


def test_apply_chunked_equals_whole(session):
    d = session
    for chunk in ("37", "1000000"):
        assert (
            main(
                [
                    "--quiet",
                    "apply",
                    str(d / "r.json"),
                    str(d / "s.csv"),
                    "--out",
                    str(d / f"c{chunk}.csv"),
                    "--chunk-rows",
                    chunk,
                ]
            )
            == 0
        )
    a, b = read_imu(d / "c37.csv"), read_imu(d / "c1000000.csv")
    assert len(a) == len(read_imu(d / "s.csv")) > 37 * 20
    for name in ("t", "acc", "gyr"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("method, extra", [("iframe", []), ("mekf", []), ("qn", ["--no-input-stage"]), ("cg", [])])
def test_attitude_chunked_equals_whole(session, method, extra):
    """The streamed estimate (state carried across blocks of 53 rows) equals the one-block estimate, and both
    equal the library's whole-log estimate."""
    from optinav.attitude import estimate

    d = session
    corrected = d / "corr.csv"
    if not corrected.exists():
        assert main(["--quiet", "apply", str(d / "r.json"), str(d / "s.csv"), "--out", str(corrected)]) == 0
    out = {}
    for chunk in ("53", "1000000"):
        assert (
            main(
                [
                    "--quiet",
                    "attitude",
                    str(corrected),
                    "--method",
                    method,
                    *extra,
                    "--chunk-rows",
                    chunk,
                    "--out",
                    str(d / f"a{chunk}.csv"),
                ]
            )
            == 0
        )
        out[chunk] = np.loadtxt(d / f"a{chunk}.csv", delimiter=",", skiprows=1)
    log = read_imu(corrected)
    assert out["53"].shape == (len(log), 8)
    np.testing.assert_allclose(out["53"], out["1000000"], rtol=1e-12, atol=1e-12)
    dt = np.diff(log.t, prepend=log.t[0] - (log.t[1] - log.t[0]))
    q = estimate(log.gyr, log.acc, dt, method=method, input_stage="--no-input-stage" not in extra).q_b_n
    np.testing.assert_allclose(out["53"][:, 1:5], q, rtol=0, atol=1e-8)  # the CSV keeps 9 digits


def test_attitude_gaps_across_blocks(tmp_path, session):
    """A time gap: refused (the same one-line error), or with --allow-gaps restarted at the same samples."""
    log = read_imu(session / "s.csv")
    acc, gyro = log.acc * 1.0, log.gyr * 1.0
    t = log.t.copy()
    t[300:] += 20.0
    p = tmp_path / "gap.csv"
    write_imu(p, ImuLog(t=t, acc=acc, gyr=gyro))
    out = {}
    for chunk in ("41", "1000000"):
        assert main(["--quiet", "attitude", str(p), "--chunk-rows", chunk, "--out", str(tmp_path / "x.csv")]) == 2
        assert not (tmp_path / "x.csv").exists()
        assert (
            main(
                [
                    "--quiet",
                    "attitude",
                    str(p),
                    "--allow-gaps",
                    "--method",
                    "gd",
                    "--chunk-rows",
                    chunk,
                    "--out",
                    str(tmp_path / f"g{chunk}.csv"),
                ]
            )
            == 0
        )
        out[chunk] = np.loadtxt(tmp_path / f"g{chunk}.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(out["41"], out["1000000"], rtol=1e-12, atol=1e-12)


# --- magnetometer, polarization and reference columns streamed (issue 17) ----------------------------------------

#: a magnetic field in the navigation frame (µT, NED: north, east, down; no declination: iframe heads to magnetic north)
_M_NED = np.array([30.0, 0.0, 40.0])


@pytest.fixture(scope="module")
def flight_log(tmp_path_factory):
    """A simulated dynamic flight (seed 4, 40 s at 100 Hz) with the polarization columns of the simulator and a
    magnetometer (the field rotated into the body by the true attitude, 0.3 µT noise), as one CSV."""
    from optinav.attitude.simulate import simulate
    from optinav.core.rotations import quat_conjugate, quat_rotate

    d = simulate("dynamic", duration_s=40.0, rate_hz=100.0, rng=4)
    rng = np.random.default_rng(5)
    mag = quat_rotate(quat_conjugate(d.q_b_n), np.broadcast_to(_M_NED, d.acc.shape)) + rng.normal(0, 0.3, d.acc.shape)
    p = tmp_path_factory.mktemp("flight") / "flight.csv"
    np.savetxt(
        p,
        np.column_stack([d.t, d.acc, d.gyr, mag, np.degrees(d.aop), d.dop]),
        delimiter=",",
        fmt="%.10g",
        header="# units: t=s acc=m/s^2 gyro=rad/s\nt,ax,ay,az,gx,gy,gz,mx,my,mz,aop_deg,dop",
        comments="",
    )
    return p, d


def _streamed_and_whole(monkeypatch, tmp_path, argv, capsys):
    """The attitude CSV's hash and the summary line of the streamed path (blocks of 37 and of 10⁶ rows) and of the
    in-memory path."""
    import optinav.cli.attitude as cli

    got = {}
    for chunk in ("37", "1000000"):
        out = tmp_path / f"s{chunk}.csv"
        assert main(["--quiet", "attitude", *argv, "--chunk-rows", chunk, "--out", str(out)]) == 0
        got[chunk] = (hashlib.sha256(out.read_bytes()).hexdigest(), capsys.readouterr().out.splitlines()[0])
    monkeypatch.setattr(cli, "_streams", lambda args: False)
    out = tmp_path / "whole.csv"
    assert main(["--quiet", "attitude", *argv, "--out", str(out)]) == 0
    got["whole"] = (hashlib.sha256(out.read_bytes()).hexdigest(), capsys.readouterr().out.splitlines()[0])
    return got


def test_attitude_mag_streamed_equals_whole(monkeypatch, tmp_path, flight_log, capsys):
    """iframe with the magnetometer: the streamed CSV is the in-memory one byte for byte, the summary line (the
    fraction of samples with the magnetometer used) the same, and the heading follows the field (yaw error
    against the truth a few degrees, not the gyro's drift)."""
    p, d = flight_log
    got = _streamed_and_whole(monkeypatch, tmp_path, [str(p), "--mag"], capsys)
    assert got["37"] == got["1000000"] == got["whole"]
    assert "magnetometer used" in got["37"][1]
    q = np.loadtxt(tmp_path / "s37.csv", delimiter=",", skiprows=1)[:, 1:5]
    from optinav.attitude.metrics import heading_error

    assert np.degrees(np.sqrt(np.mean(heading_error(q[1000:], d.q_b_n[1000:]) ** 2))) < 5.0


def test_attitude_pol_streamed_equals_whole(monkeypatch, tmp_path, flight_log, capsys):
    """MEKF with the polarization columns (sun from place and time per block): the streamed CSV equals the in-memory
    one to the last printed digit and the counts of polarization used/skipped are the same. Not byte for byte:
    the SPA interpolates its slow terms on a grid anchored at the first time it is given, so a block's sun
    vector differs from the whole log's by ~1e-13, which flips the 9th digit of a few rows."""
    p, d = flight_log
    e0 = np.degrees(d.euler[0])
    argv = [
        str(p),
        "--method",
        "mekf",
        "--pol-columns",
        "aop_deg,dop",
        "--aop-unit",
        "deg",
        "--lat",
        "38.8814192",
        "--lon",
        "121.528255",
        "--start-time",
        str(d.start_time),
        "--q0-deg",
        ",".join(f"{v:.6f}" for v in e0),
    ]
    got = _streamed_and_whole(monkeypatch, tmp_path, argv, capsys)
    assert got["37"][1] == got["1000000"][1] == got["whole"][1]
    a, b = (np.loadtxt(tmp_path / f, delimiter=",", skiprows=1) for f in ("s37.csv", "whole.csv"))
    np.testing.assert_array_equal(a[:, 0], b[:, 0])
    np.testing.assert_allclose(a[:, 1:5], b[:, 1:5], rtol=0, atol=2e-9)  # 9 significant digits
    assert "polarization used" in got["37"][1]
    used = int(got["37"][1].split("polarization used ")[1].split(",")[0])
    assert used > 0.5 * np.count_nonzero(np.isfinite(d.aop))


@pytest.mark.parametrize(
    "extra", [[], ["--mag"], ["--option", "latency=0.004", "--q0-deg", "1,-2,30"]], ids=["plain", "mag", "latency-q0"]
)
def test_attitude_offline_streamed_equals_whole(monkeypatch, tmp_path, flight_log, capsys, extra):
    """iframe --offline through the scratch file (forward, backward and zero-phase passes in blocks of 37 rows,
    states carried): the CSV is the in-memory smoother's byte for byte, the summary line the same, no scratch file
    is left, and the smoothed tilt is at least as close to the truth as the online one."""
    from optinav.attitude.metrics import inclination_error

    p, d = flight_log
    got = _streamed_and_whole(monkeypatch, tmp_path, [str(p), "--offline", *extra], capsys)
    assert got["37"] == got["1000000"] == got["whole"]
    assert got["37"][1].startswith("iframe offline")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["s1000000.csv", "s37.csv", "whole.csv"]
    assert main(["--quiet", "attitude", str(p), *extra, "--out", str(tmp_path / "online.csv")]) == 0
    off, on = (np.loadtxt(tmp_path / f, delimiter=",", skiprows=1)[:, 1:5] for f in ("s37.csv", "online.csv"))
    rms = [np.degrees(np.sqrt(np.mean(inclination_error(q, d.q_b_n) ** 2))) for q in (off, on)]
    assert rms[0] <= rms[1] and rms[0] < 2.0, rms


def _pol_log(path, level: bool):
    """A 40-s log (100 Hz, NED) with an AoP column (rad) of a zenith-viewing sensor, the sun fixed at azimuth 120°,
    elevation 30°, a start at heading 150° (beyond the |ψ| ≤ 90° branch a start takes): tilting motion, or a level
    body yawing (``level``). Returns the true q_b^n (N, 4)."""
    from optinav.attitude import DEFAULT_C_B_M, predicted_aop
    from optinav.core.rotations import quat_from_euler, quat_from_rotvec, quat_multiply, quat_rotate, quat_conjugate

    n, rng = 4000, np.random.default_rng(1)
    t = np.arange(n) / 100.0
    w = np.column_stack([0.8 * np.sin(2 * np.pi * f * t + p) for f, p in ((0.11, 0.3), (0.07, 1.1), (0.05, 2.0))])
    if level:
        w[:, :2] = 0.0
    q, cur = np.empty((n, 4)), quat_from_euler(np.radians([0.0, 0.0, 150.0]) if level else [0.1, -0.05, 2.618])
    for i, dq in enumerate(quat_from_rotvec(w * 0.01)):
        q[i] = cur = quat_multiply(cur, dq)
    az, el = np.radians(120.0), np.radians(30.0)
    sun = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), -np.sin(el)])
    aop = predicted_aop(q, sun, DEFAULT_C_B_M) + rng.normal(0.0, np.radians(1.0), n)
    acc = quat_rotate(quat_conjugate(q), np.broadcast_to([0.0, 0.0, -9.81], (n, 3))) + rng.normal(0, 0.05, (n, 3))
    gyr = w + rng.normal(0.0, 0.005, (n, 3))
    np.savetxt(path, np.column_stack([t, acc, gyr, (aop + np.pi / 2) % np.pi - np.pi / 2]), delimiter=",",
               fmt="%.10g", header="# units: t=s acc=m/s^2 gyro=rad/s\nt,ax,ay,az,gx,gy,gz,aop", comments="")  # fmt: skip
    return q


_POL_SUN = ["--pol-columns", "aop", "--sun-azimuth", "120", "--sun-elevation", "30"]


@pytest.mark.parametrize("extra", [[], ["--method", "iframe"], ["--offline"]], ids=["mekf", "iframe", "offline"])
def test_attitude_pol_heading_branch_streamed_equals_whole(monkeypatch, tmp_path, capsys, extra):
    """Polarization alone, no --q0-deg, a start at heading 150° with tilting motion: the file read in blocks takes
    the branch the AoP shows (iframe from either, as estimate() decides it; 180° off before with exit 0), the CSV the
    in-memory path's byte for byte (blocks of 37 and 10⁶ rows) and the summary line the same; a level body yawing
    is refused in one line naming --q0-deg, before anything is written."""
    from optinav.attitude.metrics import heading_error

    p = tmp_path / "pol.csv"
    q = _pol_log(p, level=False)
    got = _streamed_and_whole(monkeypatch, tmp_path, [str(p), *_POL_SUN, *extra], capsys)
    assert got["37"] == got["1000000"] == got["whole"]
    assert "heading branch chosen by the data" in got["37"][1]
    est = np.loadtxt(tmp_path / "s37.csv", delimiter=",", skiprows=1)[:, 1:5]
    assert np.degrees(np.sqrt(np.mean(heading_error(est[1000:], q[1000:]) ** 2))) < 0.5
    _pol_log(p, level=True)
    out = tmp_path / "level.csv"
    assert main(["--quiet", "attitude", str(p), *_POL_SUN, *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "ambiguous by 180°" in err and "--q0-deg" in err and err.count("\n") == 1 and not out.exists()


def test_attitude_offline_refuses_a_full_disk_up_front(monkeypatch, tmp_path, flight_log, capsys):
    """Too little free space for the scratch file: a one-line error with the estimate, before any estimate, and no
    file left."""
    import optinav.attitude.filestream as fs

    monkeypatch.setattr(fs, "_free_bytes", lambda path: 1000.0)
    p, _ = flight_log
    assert main(["--quiet", "attitude", str(p), "--offline", "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "--offline needs" in err and "GiB" in err and "drop --offline" in err
    assert not any(tmp_path.iterdir())


def test_attitude_offline_gaps_streamed_equals_whole(monkeypatch, tmp_path, session, capsys):
    """--offline over time gaps: refused without --allow-gaps (no output, no scratch file); with it each segment
    is smoothed on its own, streamed (blocks of 37 rows, gaps inside blocks) byte for byte as in memory."""
    log = read_imu(session / "s.csv")
    t = log.t.copy()
    t[300:] += 20.0
    t[1234:] += 7.5
    p = tmp_path / "gap.csv"
    write_imu(p, ImuLog(t=t, acc=log.acc, gyr=log.gyr))
    out = tmp_path / "o" / "x.csv"
    out.parent.mkdir()
    assert main(["--quiet", "attitude", str(p), "--offline", "--chunk-rows", "37", "--out", str(out)]) == 2
    assert "time gap" in capsys.readouterr().err and not any(out.parent.iterdir())
    got = _streamed_and_whole(monkeypatch, out.parent, [str(p), "--offline", "--allow-gaps"], capsys)
    assert got["37"] == got["1000000"] == got["whole"]
    assert "3 segments" in got["37"][1]


def _broad_like(path, d, rng):
    """A simulated trial in BROAD's layout (ENU, imu_gyr/imu_acc/imu_mag, opt_quat with dropouts, movement)."""
    import h5py

    from optinav.core.rotations import quat_conjugate, quat_rotate

    n = d.t.size
    m_enu = np.array([0.0, 30.0, -40.0])
    mag = quat_rotate(quat_conjugate(d.q_b_n), np.broadcast_to(m_enu, d.acc.shape)) + rng.normal(0, 0.3, (n, 3))
    q_ref = d.q_b_n.copy()
    q_ref[rng.choice(n, n // 20, replace=False)] = np.nan  # the optical system lost the markers
    with h5py.File(path, "w") as f:
        f.attrs["sampling_rate"] = 100.0
        for k, v in (
            ("imu_gyr", d.gyr),
            ("imu_acc", d.acc),
            ("imu_mag", mag),
            ("opt_quat", q_ref),
            ("movement", (d.t > 5.0).astype(np.uint8)),
        ):
            f.create_dataset(k, data=v)


def _reference_scores(path, chunk, mag=True, offline=False, frame="ENU"):
    from optinav.attitude.filestream import stream_attitude
    from optinav.attitude.unit import AttitudeOptions, run_unit

    o = AttitudeOptions(frame=frame, mag=mag, offline=offline)
    run = stream_attitude(path, path.with_name(f"ref{chunk}.csv"), o, reference=True, chunk_rows=chunk, progress=False)
    _, extra = run_unit(path, o, reference=True)
    # the library's score is in radians, the result's extras in degrees (file I/O)
    return (*np.degrees(run.score[:2]), run.score[2]), (
        extra["inclination_rmse_deg"],
        extra["heading_rmse_deg"],
        extra["n_reference"],
    )


@pytest.mark.parametrize("chunk", [97, 10_000_000])
def test_reference_score_streamed_simulated(tmp_path, chunk):
    """A simulated BROAD-layout trial: the score accumulated block by block equals the whole-run RMSE to 1e-12,
    and the RMSEs are those of an estimate against its truth (a few degrees in the manoeuvres)."""
    from optinav.attitude.simulate import simulate

    d = simulate("dynamic", duration_s=30.0, rate_hz=100.0, frame="ENU", rng=7)
    p = tmp_path / "sim_trial.hdf5"
    _broad_like(p, d, np.random.default_rng(8))
    import h5py

    with h5py.File(p, "r") as f:
        valid = (d.t > 5.0) & np.isfinite(f["opt_quat"][()]).all(axis=1)
    streamed, whole = _reference_scores(p, chunk)
    np.testing.assert_allclose(streamed[:2], whole[:2], rtol=1e-12, atol=0)
    assert streamed[2] == whole[2] == np.count_nonzero(valid)
    # a dynamic flight (2-3 m/s² manoeuvres) tilts the online estimate by a few degrees at most
    assert 0.05 < streamed[0] < 5.0 and 0.05 < streamed[1] < 10.0


def test_reference_score_streamed_offline(tmp_path):
    """The offline smoother on a BROAD-layout trial, streamed in blocks of 97 rows: its score equals the in-memory
    one to 1e-12 and is below the online filter's (the smoother sees the whole recording)."""
    from optinav.attitude.simulate import simulate

    d = simulate("dynamic", duration_s=30.0, rate_hz=100.0, frame="ENU", rng=7)
    p = tmp_path / "sim_trial.hdf5"
    _broad_like(p, d, np.random.default_rng(8))
    streamed, whole = _reference_scores(p, 97, offline=True)
    np.testing.assert_allclose(streamed[:2], whole[:2], rtol=1e-12, atol=0)
    assert streamed[2] == whole[2]
    online, _ = _reference_scores(p, 97)
    assert streamed[0] < online[0]


def test_reference_score_streamed_offline_upside_down_frame(tmp_path):
    """The same right-forward-up trial run in NED (its body hangs upside down there, roll 180°), streamed in
    blocks of 97 rows: the offline 9D heading is the one the ENU run gives (it was not: the gyro's heading was
    the twist of a 180° tilt, undefined; here 67° apart; BROAD trial 29 in NED scored 23.9° against 1.59°). Not to
    rounding: each frame starts at its own yaw 0 (90° apart) until the field takes over, which leaves the online
    runs 4e-4° apart too."""
    from optinav.attitude.simulate import simulate

    d = simulate("dynamic", duration_s=30.0, rate_hz=100.0, frame="ENU", rng=7)
    p = tmp_path / "sim_trial.hdf5"
    _broad_like(p, d, np.random.default_rng(8))
    enu, _ = _reference_scores(p, 97, offline=True)
    ned, whole = _reference_scores(p, 97, offline=True, frame="NED")
    np.testing.assert_allclose(ned[:2], whole[:2], rtol=1e-12, atol=0)
    np.testing.assert_allclose(ned[:2], enu[:2], rtol=0, atol=5e-3)


_BROAD = (
    Path(__file__).resolve().parents[1]
    / ".."
    / "shared"
    / "data"
    / "attitude"
    / "broad"
    / "02_undisturbed_slow_rotation_B.hdf5"
)


@pytest.mark.skipif(not _BROAD.is_file(), reason=f"BROAD data absent ({_BROAD})")
def test_reference_score_streamed_broad(tmp_path):
    """BROAD trial 02 (real, optical reference) with the magnetometer: the streamed score equals the in-memory
    one to 1e-12, and the inclination RMSE is the filter's sub-degree one."""
    import shutil

    p = tmp_path / _BROAD.name
    shutil.copy(_BROAD, p)
    streamed, whole = _reference_scores(p, 5003)
    np.testing.assert_allclose(streamed[:2], whole[:2], rtol=1e-12, atol=0)
    assert streamed[2] == whole[2] > 1000
    assert streamed[0] < 1.0


# --- calibrate accel reads in blocks (issue 17, item 6) -----------------------------------------------------------


def _whole_session(path, o):
    """The session as the whole-file reader gives it (what calibrate read before it streamed)."""
    from optinav.io import raw_units
    from optinav.multipos.calibrate import SessionData

    log = read_imu(path, columns=o.columns, acc_unit=o.acc_unit, gyro_unit=o.gyro_unit, rate_hz=o.rate_hz)
    acc, acc_unit = raw_units(log, "acc")
    gyro, gyro_unit = (None, None) if o.no_gyro or log.gyr is None else raw_units(log, "gyro")
    return SessionData(log.t, acc, acc_unit, gyro, gyro_unit, log.labels, tuple(log.notes))


def _imucal(name):
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "imucal" / name
    if not path.is_file():
        pytest.skip("imucal data absent")
    return path


@pytest.mark.parametrize("case", ["simulated", "annotated", "ferraris"])
def test_calibrate_reads_in_blocks_exactly_as_the_whole_file(session, case):
    """Blocks of 997 rows give the same arrays, labels and notes as the whole-file reader, hence the same
    calibration (compared as written, field by field; only the run time differs)."""
    import json

    from optinav.multipos.calibrate import FileOptions, calibrate_data, read_session_file

    if case == "simulated":
        path, o = session / "s.csv", FileOptions(lat_deg=38.88, height_m=35)
    elif case == "annotated":
        path = _imucal("annotated_session.csv")
        o = FileOptions(rate_hz=204.8, acc_unit="counts", gyro_unit="counts", gravity=9.81, no_gyro=True)
    else:
        path = _imucal("example_ferraris_session.csv")
        o = FileOptions(
            rate_hz=102.4,
            gyro_unit="deg/s",
            gravity=9.81,
            method="ferraris",
            sections=str(path.with_name("example_ferraris_session_list.json")),
        )
    whole = _whole_session(path, o)
    blocks = read_session_file(path, o, chunk_rows=997)
    assert len(whole.t) > 3 * 997
    for name in ("t", "acc", "gyr", "labels"):
        w, b = getattr(whole, name), getattr(blocks, name)
        assert (w is None) == (b is None), name
        if w is not None:
            assert w.dtype == b.dtype and np.array_equal(w, b), name
    assert (whole.acc_unit, whole.gyro_unit, whole.notes) == (blocks.acc_unit, blocks.gyro_unit, blocks.notes)
    results = []
    for data in (whole, blocks):
        r = json.loads(calibrate_data(data, o).to_json())
        r.pop("elapsed_s")
        r["fields"].pop("elapsed_s")
        results.append(r)
    assert results[0] == results[1]


@pytest.mark.skipif(os.name != "posix", reason="an open file is unnamed only on POSIX")
def test_a_killed_process_leaves_no_scratch_file(tmp_path):
    """`batch attitude --offline` killed with SIGKILL (its workers die with it) left a 12.8 MB scratch file per unit
    in flight in the temporary folder (BROAD 02, one per kill). The scratch file has no name while it is in
    use, so nothing is left; it still reads back what was written."""
    import signal
    import subprocess
    import sys

    code = (
        "import os, signal, sys\n"
        "from optinav.core.files import scratch_file\n"
        "with scratch_file(sys.argv[1]) as fh:\n"
        "    fh.write(b'0123456789' * 1000); fh.flush(); fh.seek(5)\n"
        "    assert fh.read(5) == b'56789'\n"
        "    print(len(os.listdir(os.path.dirname(sys.argv[1]))), flush=True)\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "a.csv")], capture_output=True, text=True, env=env)
    assert r.returncode == -signal.SIGKILL, r.stderr
    assert r.stdout.strip() == "0"  # unnamed while in use
    assert not any(tmp_path.iterdir())


def test_csv_blocks_are_the_text_numpy_savetxt_writes(tmp_path):
    """The CSV writer formats a block in one go (numpy.savetxt formats row by row, twice the time on attitude
    tables): byte for byte savetxt's text for the formats the writers use (one, one per column, several in one
    string), NaN/inf, integers, float32 and a single column; an unusable format is savetxt's own error."""
    from optinav.attitude.recording import CSV_FORMAT
    from optinav.core.files import csv_writer

    rng = np.random.default_rng(5)
    x = rng.normal(size=(5000, 8)) * 10.0 ** rng.integers(-12, 12, (5000, 8))
    x[3, 2], x[4, 1], x[5, 0], x[6, 3] = np.nan, np.inf, -np.inf, -0.0
    cases = [(x, CSV_FORMAT), (x, "%.12g"), (x[:, :2], "%.3f;%.5e"), (x[:, 0], "%.17g"), (x[:0], "%.9g")]
    cases += [(x.astype(np.float32), "%.9g"), (rng.integers(-(10**12), 10**12, (300, 3)), "%d")]
    for k, (table, fmt) in enumerate(cases):
        with csv_writer(tmp_path / f"a{k}.csv", "h", fmt) as write:
            for i in range(0, max(len(table), 1), 1700):
                write(table[i : i + 1700])
        want = io.StringIO()
        np.savetxt(want, table, delimiter=",", fmt=fmt)
        assert (tmp_path / f"a{k}.csv").read_text() == "h\n" + want.getvalue(), fmt
    with (
        pytest.raises(AttributeError, match="fmt has wrong shape"),
        csv_writer(tmp_path / "bad.csv", "h", ["%g"] * 3) as write,
    ):
        write(x)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 80), cuts=st.lists(st.integers(1, 79), max_size=6), seed=st.integers(0, 2**16))
def test_gyro_wraps_fed_in_blocks_equal_the_whole(n, cuts, seed):
    """checks.Wraps over any split of a log into blocks finds the flip the whole log has, at a block's edge too."""
    from optinav.attitude.checks import Wraps

    rng = np.random.default_rng(seed)
    fs = 4.0
    gyr = (rng.normal(0.0, 3.0, (n, 3)).cumsum(axis=0) + fs) % (2 * fs) - fs
    whole, parts = Wraps(), Wraps()
    whole.add(gyr)
    for a, b in zip([0, *sorted(set(c for c in cuts if c < n))], [*sorted(set(c for c in cuts if c < n)), n]):
        parts.add(gyr[a:b])
    for attr in ("peak", "flip", "row", "pair", "n"):
        np.testing.assert_array_equal(getattr(parts, attr), getattr(whole, attr))
