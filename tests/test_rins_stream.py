"""Rotational-INS chain block by block (issue 17): any block length gives the whole log's numbers bit for bit, and
the bad-input errors are raised the same when the fault straddles a block boundary."""

import dataclasses

import numpy as np
import pytest

from optinav.core import earth
from optinav.core.strapdown import attitude_update
from optinav.errors import OptinavError
from optinav.rins.calibrate import calibrate, prepare
from optinav.rins.io import ArraySource, RinsFile, write_rins
from optinav.rins.process import sensor_attitude_from_imu, strapdown_blocks, survey
from optinav.rins.simulate import simulate
from optinav.rins.unit import compensated_attitude

P_TRUE = np.array([1.0, -2.0, 3.0, -1.0, 2.0, 4.0]) * 1e-4
SHORT = dict(scheme="dual4", align_s=60.0, dwell_s=10.0, move_s=5.0, rate_hz=100.0)
ARC = np.radians(1 / 3600)
BLOCKS = (37, 1000)


@pytest.fixture(scope="module")
def session():
    return simulate(P_TRUE, rng=3, gyro_misalignment=20 * ARC, lock_sigma=3 * ARC, **SHORT)


def _same_alignment(a, b):
    for x, y in zip(dataclasses.astuple(a), dataclasses.astuple(b)):
        np.testing.assert_array_equal(x, y)


def _whole(d):
    return ArraySource(d, block_rows=d.t.size)


def test_strapdown_blocks_are_the_whole_log_integration(session):
    """The attitude carried across blocks of 37 rows is attitude_update over the whole log, bit for bit."""
    d = session
    al = survey(d)
    ref = attitude_update(
        al.q0, d.dtheta[al.m : -1], omega_in_n=earth.earth_rate(d.lat, "enu"), dt=np.diff(d.t)[al.m :]
    )
    got = np.concatenate([nb.q for nb in strapdown_blocks(ArraySource(d, 37), al)])
    assert got.shape == (d.t.size - al.m, 4) and al.m == 6019
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("rows", BLOCKS)
def test_prepare_and_calibrate_blockwise_equal_whole_log(session, rows):
    whole = prepare(_whole(session))
    part = prepare(ArraySource(session, rows))
    assert whole.t.size == 599 and whole.c_s_n.shape == (599, 3, 3)  # 10 Hz epochs kept, not the 100 Hz log
    for f in ("t", "c_s_n", "alpha", "beta", "index"):
        np.testing.assert_array_equal(getattr(part, f), getattr(whole, f))
    _same_alignment(part.align, whole.align)
    assert len(whole.perturbed) == 9
    for k, (spill, i) in whole.perturbed.items():  # the re-integrations wait in a scratch file
        q = spill.read(i)
        assert q.shape == (599, 4)
        np.testing.assert_array_equal(part.perturbed[k][0].read(part.perturbed[k][1]), q)
    assert [len(part.moves[a]) for a in "ZY"] == [2, 2]
    for a in "ZY":
        for (u, d, o), (u2, d2, o2) in zip(part.moves[a], whole.moves[a]):
            np.testing.assert_array_equal(u, u2)
            assert (d, o) == (d2, o2)
    for method in ("lm", "axis"):
        a, b = calibrate(method=method, prep=part), calibrate(method=method, prep=whole)
        assert a.p_used == b.p_used and a.angles_std == b.angles_std
        assert a.rmse_before_deg == b.rmse_before_deg and a.rmse_after_deg == b.rmse_after_deg
        assert a.gates == b.gates
    # gyro errors of another size: one more pass, the same numbers
    a = calibrate(method="lm", prep=part, gyro_misalignment=60 * ARC)
    b = calibrate(method="lm", prep=whole, gyro_misalignment=60 * ARC)
    assert a.angles_std == b.angles_std and a.angles_std != calibrate(method="lm", prep=whole).angles_std


def test_files_in_blocks_equal_the_data_in_memory(session, tmp_path):
    """A CSV read in 37-row blocks (twice: checks and alignment, then strapdown) and the older 'time' layout,
    whose rows pair across block boundaries, give the in-memory numbers."""
    d = session
    path = write_rins(tmp_path / "s.csv", d)
    want = prepare(d)
    got = prepare(RinsFile(path, block_rows=37))
    np.testing.assert_array_equal(got.c_s_n, want.c_s_n)
    _same_alignment(got.align, want.align)
    end = np.column_stack([d.t[1:], d.dtheta[:-1], d.dv[:-1], d.alpha[1:], d.beta[1:]])
    old = tmp_path / "old.csv"
    head = "# optinav rins: lat_deg=28.2 height_m=0\ntime,dtheta_x,dtheta_y,dtheta_z,dv_x,dv_y,dv_z,alpha,beta"
    np.savetxt(old, end, delimiter=",", header=head, comments="", fmt="%.17g")
    blocks = list(RinsFile(old, block_rows=37))
    assert [b.row0 for b in blocks[:3]] == [0, 36, 73] and sum(b.t.size for b in blocks) == d.t.size - 2
    whole = list(RinsFile(old, block_rows=10**6))[0]
    for f in ("t", "dtheta", "alpha", "beta"):
        np.testing.assert_array_equal(np.concatenate([getattr(b, f) for b in blocks]), getattr(whole, f))
    np.testing.assert_array_equal(whole.dtheta, d.dtheta[1:-1])


def test_compensated_attitude_blockwise_equals_whole(session):
    p = np.array(P_TRUE)
    t1, c1 = compensated_attitude(p, ArraySource(session, 37))
    t0, c0 = compensated_attitude(p, _whole(session))
    np.testing.assert_array_equal(t1, t0)
    np.testing.assert_array_equal(c1, c0)
    sa = sensor_attitude_from_imu(session)
    assert c0.shape == sa.c_s_n.shape and sa.t[0] == sa.align_end == t0[0]


def _errors(d, match):
    """The error of the whole log and of blocks of 37 and 1000 rows: the same one-line message."""
    msgs = set()
    for rows in (d.t.size, *BLOCKS):
        with pytest.raises(OptinavError, match=match) as e:
            calibrate(ArraySource(d, rows), "lm")
        msgs.add(str(e.value))
    assert len(msgs) == 1, msgs
    return msgs.pop()


def test_gap_and_unsorted_time_across_a_block_boundary(session):
    keep = np.r_[0:1000, 1011 : session.t.size]  # rows 1000..1010 missing: the gap starts at row 999
    gap = dataclasses.replace(session, **{f: getattr(session, f)[keep] for f in ("t", "dtheta", "dv", "alpha", "beta")})
    assert "gap of 0.12 s at t = 9.99 s (nominal step 0.01 s)" in _errors(gap, "gap of")
    t = session.t.copy()
    t[[999, 1000]] = t[[1000, 999]]
    assert "t[1000] = 9.99 s < t[999] = 10 s" in _errors(dataclasses.replace(session, t=t), "not sorted")


def test_frozen_encoder_across_block_boundaries(session):
    """The outer encoder stuck during its first move (~2000 rows, every 37-row block boundary inside it)."""
    d = session
    moves = np.flatnonzero(np.abs(np.diff(d.beta)) > 1e-4)
    first = moves[moves < moves[0] + 1000]  # the first outer move
    beta = d.beta.copy()
    beta[first[0] :] = np.where(np.arange(first[0], d.t.size) <= first[-1] + 1, beta[first[0]], beta[first[0] :])
    beta[first[-1] + 2 :] = d.beta[first[-1] + 2 :] - d.beta[first[-1] + 1] + beta[first[0]]
    msg = _errors(dataclasses.replace(d, beta=beta), "encoder channel is frozen")
    t_bad = float(msg.split("at t = ")[1].split(" s")[0])
    assert d.t[first[0]] < t_bad < d.t[first[-1]]


def test_swapped_encoders_wrong_latitude_and_held_encoder(session):
    d = session
    _errors(dataclasses.replace(d, alpha=d.beta, beta=d.alpha), "swapped|frozen")
    msg = _errors(dataclasses.replace(d, lat=np.radians(-10.0)), "disagrees with the")
    assert msg.startswith("the latitude -10° disagrees with the 28.")
    held = d.alpha.copy()
    held[1::2] = held[0::2][: held[1::2].size]  # sampled at half the IMU rate, held
    assert "(100 Hz)" in _errors(dataclasses.replace(d, alpha=held), "sampled slower than the IMU")
    with pytest.raises(OptinavError, match="has 6000 samples for 12000 IMU samples"):
        calibrate(dataclasses.replace(d, beta=d.beta[::2]), "lm")


def test_npz_column_length_mismatch_is_named(session, tmp_path):
    path = tmp_path / "s.npz"
    cols = dict(t=session.t, alpha=session.alpha, beta=session.beta[:-5], lat_deg=np.array(28.2))
    cols.update({f"dtheta_{a}": session.dtheta[:, i] for i, a in enumerate("xyz")})
    cols.update({f"dv_{a}": session.dv[:, i] for i, a in enumerate("xyz")})
    np.savez(path, **cols)
    with pytest.raises(OptinavError, match="column beta has 11995 samples for 12000 time stamps"):
        calibrate(str(path), "lm")


def test_residuals_and_jacobian_in_chunks_equal_one_evaluation(session, monkeypatch):
    """Chunks of 7 epochs (the first epoch, the reference of the attitude change, carried) give the numbers of one
    chunk over all epochs, for one parameter vector and a batch."""
    import optinav.rins.model as model

    prep = prepare(session, gyro_misalignment=0, gyro_scale=0)
    p = np.array([3e-4, -1e-4, 2e-4, 1e-4, 5e-4, -2e-4])
    P = np.stack([p, -p, 2 * p])
    args = (prep.c_s_n, prep.alpha, prep.beta)
    whole = [model.residuals(*args, p), model.residuals(*args, P, True), model.residual_jacobian(*args, p)]
    monkeypatch.setattr(model, "CHUNK_EPOCHS", 7)
    parts = [model.residuals(*args, p), model.residuals(*args, P, True), model.residual_jacobian(*args, p)]
    assert whole[0].shape == (3 * 598,) and whole[1].shape == (3, 3 * 598) and whole[2].shape == (3 * 598, 6)
    for a, b in zip(parts, whole):
        np.testing.assert_array_equal(a, b)


def test_cli_refuses_up_front_by_the_streamed_estimate(session, tmp_path, monkeypatch, capsys):
    """Text is read in blocks (100 B per row assumed), NPZ whole in each pass (300 B per row)."""
    import optinav.cli.common as common
    from optinav.cli.main import main

    monkeypatch.setattr(common, "available_memory", lambda: 1e6)
    need = {}
    for suffix in (".csv", ".npz"):
        path = write_rins(tmp_path / f"s{suffix}", session)
        assert main(["--quiet", "calibrate", "rins", str(path), "--out", str(tmp_path / "r.json")]) == 2
        err = capsys.readouterr().err
        assert "would need" in err and "Traceback" not in err
        need[suffix] = float(err.split("about ")[1].split(" GiB")[0]) * 2**30
    assert need[".csv"] == pytest.approx(12000 * 100, rel=0.05) and need[".npz"] == pytest.approx(
        12000 * 300, rel=0.005
    )


def test_a_rest_longer_than_the_alignment_keeps_is_refused_with_the_flag(session, monkeypatch):
    """The initial rest is held for the alignment up to MAX_REST_ROWS rows: a longer one (60 s, about 6000 rows,
    the cap set to 2500) ends in a one-line error naming --align without holding the rest, and --align 20 aligns
    on its first 20 s as before."""
    import optinav.rins.process as process

    want = survey(session, align_s=20.0)
    monkeypatch.setattr(process, "MAX_REST_ROWS", 2500)
    with pytest.raises(OptinavError, match=r"initial rest lasts 60 s \(60[0-9]{2} rows\).*--align S"):
        survey(session)
    _same_alignment(survey(session, align_s=20.0), want)


def test_a_gimbal_that_never_stops_is_summed_in_bounded_memory():
    """The axis method's move summation keeps a few epochs of history, whatever the length of a move: an inner
    gimbal turning at 30 °/s from epoch 100 to the end of the data (3000 epochs) gives one move, its axis the
    increments' (z) and its angle the encoders', the same bits for blocks of 64 epochs and for one block."""
    from types import SimpleNamespace

    from optinav.rins.calibrate import _AxisMoves
    from optinav.rins.process import NavBlock

    n, dt = 3100, 0.01
    alpha = np.concatenate([np.zeros(101), np.radians(30.0) * dt * np.arange(1, n - 100)])
    al = SimpleNamespace(lat=np.radians(40.0))
    w_ie = earth.earth_rate(al.lat, "enu")
    dth = np.column_stack([np.zeros((n - 1, 2)), np.diff(alpha)]) + w_ie * dt  # the Earth rate removed again

    def run(rows):
        moves = _AxisMoves(al)
        for a in range(0, n - 1, rows):
            b = min(a + rows, n - 1)
            k = b - a
            e0 = 0 if a == 0 else a + 1  # the first block brings the start epoch too
            moves.feed(
                NavBlock(
                    j0=e0,
                    t=np.arange(e0, b + 1) * dt,
                    q=np.tile([1.0, 0, 0, 0], (b + 1 - e0, 1)),
                    alpha=alpha[e0 : b + 1],
                    beta=np.zeros(b + 1 - e0),
                    dtheta=dth[a:b],
                    dt=np.full(k, dt),
                    q_start=np.tile([1.0, 0, 0, 0], (k, 1)),
                    perturbed=[],
                )
            )
            assert moves.ang["Z"].size <= moves.MARGIN + 2 and moves.rel.shape[0] <= moves.MARGIN + 2
        return moves.finish()

    out = run(64)
    ((u, d_ang, other),) = out["Z"]
    assert out["Y"] == [] and d_ang == alpha[-1] - alpha[95] and other == 0.0
    np.testing.assert_allclose(u, [0.0, 0.0, 1.0], atol=1e-12)
    (whole,) = run(n)["Z"]
    assert np.array_equal(whole[0], u) and whole[1:] == (d_ang, other)
