"""Simulations generated and written block by block (issue 17, bounded memory): the same seed gives the same samples
whatever the block length, the noise keeps its statistics across blocks, and the streamed file is the library's
session."""

from __future__ import annotations

import json

import numpy as np
import pytest

from optinav.cli.main import main
from optinav.core.imu_model import (
    DRAW_BLOCK,
    ImuModel,
    MeasurementStream,
    SampleDraws,
    TriadNoise,
    preset,
)
from optinav.io import read_imu, write_imu
from optinav.multipos.simulate import SessionStream, simulate


def _gather(blocks):
    return [np.concatenate(p) for p in zip(*blocks)]


def test_sample_draws_do_not_depend_on_the_split():
    d = SampleDraws(7, 2)
    whole = d.take(DRAW_BLOCK - 50, DRAW_BLOCK + 70)  # across a draw block
    cut = [0, 13, 50, 51, 120]
    parts = np.concatenate(
        [SampleDraws(7, 2).take(DRAW_BLOCK - 50 + a, DRAW_BLOCK - 50 + b) for a, b in zip(cut, cut[1:])]
    )
    assert np.array_equal(whole, parts)
    assert not np.array_equal(whole, SampleDraws(7, 3).take(DRAW_BLOCK - 50, DRAW_BLOCK + 70))  # streams differ
    assert np.all(
        (SampleDraws(7, 6, 1, "uniform").take(0, 1000) >= 0) & (SampleDraws(7, 6, 1, "uniform").take(0, 1000) < 1)
    )


@pytest.mark.parametrize("dist", ["normal", "uniform"])
def test_sample_draws_are_the_rows_of_their_blocks_whole_draw(dist):
    """Sample i is row i mod DRAW_BLOCK of the block's generator drawing the whole (DRAW_BLOCK, width) array at
    once, however the takes before it went (forward in small steps, back to an earlier block)."""

    def block(j):
        gen = np.random.Generator(np.random.PCG64(np.random.SeedSequence(5, spawn_key=(4, j))))
        return gen.standard_normal((DRAW_BLOCK, 3)) if dist == "normal" else gen.random((DRAW_BLOCK, 3))

    d = SampleDraws(5, 4, 3, dist)
    b0, b1 = block(0), block(1)
    for i0, i1 in ((0, 7), (7, 8), (8, 1000), (500, 600), (DRAW_BLOCK - 3, DRAW_BLOCK + 2), (20, 30)):
        want = np.concatenate([b0, b1])[i0:i1]
        assert np.array_equal(d.take(i0, i1), want)


def _model(**gyro) -> ImuModel:
    return ImuModel(gyro_noise=TriadNoise(**gyro), rate_hz=100.0)


def _stream(model, n, block, key=3):
    s = MeasurementStream(model, key)
    dt = np.full(n, 0.01)
    zero = np.zeros((n, 3))
    return np.concatenate(
        [s(zero[a : a + block], zero[a : a + block], dt[a : a + block])[0] for a in range(0, n, block)]
    )


#: white + Gauss-Markov + random walk + quantization with carry: every carried state
FULL = dict(
    white=np.full(3, 1e-3),
    gm_sigma=np.full(3, 2e-4),
    gm_tau=np.full(3, 5.0),
    random_walk=np.full(3, 1e-5),
    lsb=np.full(3, 1e-4),
)


def test_measurement_stream_does_not_depend_on_the_block_length():
    n = DRAW_BLOCK + 5000  # crosses a draw block
    ref = _stream(_model(**FULL), n, n)
    for block in (997, 4096, DRAW_BLOCK):
        assert np.array_equal(_stream(_model(**FULL), n, block), ref)


def test_streamed_noise_has_its_statistics_across_blocks():
    """Each process alone, generated in blocks of 1000 samples (200 block joints): the statistic of its steps over
    all samples against its truth, with 4-sigma tolerances of the estimates."""
    n, dt = 200_000, 0.01
    N = 1e-3
    w = _stream(_model(white=np.full(3, N)), n, 1000)
    sd = N / np.sqrt(dt)
    assert np.all(np.abs(w.std(axis=0) / sd - 1) < 4 / np.sqrt(2 * n))
    lag1 = np.sum(w[1:] * w[:-1], axis=0) / np.sum(w * w, axis=0)
    assert np.all(np.abs(lag1) < 4 / np.sqrt(n))
    # random walk: independent steps of std K·√dt (the joints included: every 1000th step)
    K = 1e-5
    steps = np.diff(_stream(_model(random_walk=np.full(3, K)), n, 1000), axis=0)
    assert np.all(np.abs(steps.std(axis=0) / (K * np.sqrt(dt)) - 1) < 4 / np.sqrt(2 * n))
    joints = steps[999::1000]
    assert np.all(np.abs(joints.std(axis=0) / (K * np.sqrt(dt)) - 1) < 4 / np.sqrt(2 * joints.shape[0]))
    # Gauss-Markov: the innovations x_k - phi x_{k-1} have std sigma·sqrt(1 - phi²), at the joints as elsewhere
    sig, tau = 2e-4, 5.0
    x = _stream(_model(gm_sigma=np.full(3, sig), gm_tau=np.full(3, tau)), n, 1000)
    phi = np.exp(-dt / tau)
    inno = (x[1:] - phi * x[:-1]) / (sig * np.sqrt(1 - phi**2))
    assert np.all(np.abs(inno.std(axis=0) - 1) < 4 / np.sqrt(2 * n))
    assert np.all(np.abs(inno[999::1000].std(axis=0) - 1) < 4 / np.sqrt(2 * 199))
    # quantization with carry: the running sum of the outputs stays within half an LSB·dt of the input's
    lsb = 1e-4
    y = _stream(_model(white=np.full(3, N), lsb=np.full(3, lsb)), n, 1000)
    assert np.allclose(np.round(y / lsb), y / lsb, atol=1e-6)
    assert np.max(np.abs(np.cumsum(y - w, axis=0) * dt)) <= 0.5 * lsb * dt * (1 + 1e-6)


def test_session_does_not_depend_on_the_block_length():
    kw = dict(dwell_s=3, rest_s=2, jitter=0.3, acc_unit="counts", gyro_unit="deg/s", rng=11, spec="mpu6000")
    ref = SessionStream(**kw)
    whole = _gather(ref.blocks(10**6))
    for block in (257, 3000):
        st = SessionStream(**kw)
        parts = _gather(st.blocks(block))
        assert all(np.array_equal(a, b) for a, b in zip(whole, parts))
        assert np.array_equal(st.session().static_intervals, ref.session().static_intervals)
    s = simulate(**kw)
    assert np.array_equal(s.acc, whole[1]) and np.array_equal(s.t, whole[0])


def test_streamed_session_matches_its_truth():
    """Per pose (rest of 20 s at 100 Hz): the mean is K·(g·up) + b and the spread the white noise of the preset,
    within 4 sigma of the estimates (white noise over the pose plus the bias instability's 1-sigma)."""
    st = SessionStream(dwell_s=20, rng=4)
    t, acc, _, labels = _gather(st.blocks(5000))
    s = st.session()
    um = st.unit_model
    gm = float(np.max(um.acc_noise.gm_sigma))
    resid = []
    for k, up in enumerate(s.up_dirs):
        a = acc[labels == k]
        m = a.shape[0]
        expect = s.acc_K @ (s.gravity * up) + s.acc_b
        tol = 4 * np.sqrt(s.acc_noise_sigma**2 / m + gm**2)
        assert np.all(np.abs(a.mean(axis=0) - expect) < tol), k
        resid.append(a - a.mean(axis=0))
    r = np.concatenate(resid)
    assert np.all(np.abs(r.std(axis=0) / s.acc_noise_sigma - 1) < 4 / np.sqrt(2 * r.shape[0]))
    # the true static intervals bound each pose's samples
    for k, (t0, t1) in enumerate(s.static_intervals):
        assert t0 == t[labels == k][0] and t1 == t[labels == k][-1]


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_written_session_is_the_library_session(tmp_path, suffix):
    """The streamed file holds what writing the library's session at once holds (the text's first comment line aside:
    it counts the samples only when written at once)."""
    out = tmp_path / f"s{suffix}"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(out), "--dwell", "2", "--rest", "1"]
    argv += ["--acc-unit", "g", "--gyro-unit", "deg/s", "--jitter", "0.2", "--seed", "9"]
    assert main(argv) == 0
    s = simulate(dwell_s=2, rest_s=1, acc_unit="g", gyro_unit="deg/s", jitter=0.2, rng=9)
    ref = write_imu(tmp_path / f"ref{suffix}", s.log(), acc_unit="g", gyro_unit="deg/s")
    if suffix == ".csv":
        assert out.read_text().splitlines()[1:] == ref.read_text().splitlines()[1:]
    else:
        a, b = np.load(out), np.load(ref)
        assert sorted(a.files) == sorted(b.files) and all(np.array_equal(a[k], b[k]) for k in a.files)
    log = read_imu(out)
    assert log.t.size == s.t.size and np.allclose(log.acc, s.acc * 9.80665, rtol=1e-15, atol=0)
    truth = json.loads(out.with_name("s.truth.json").read_text())
    assert np.array_equal(np.asarray(truth["static_intervals"]), s.static_intervals)
    assert np.array_equal(np.asarray(truth["accelerometer"]["K"]), s.acc_K)


def test_preset_draw_is_unchanged_by_streaming():
    """The unit (K, b) is drawn first from the seed, as before the noise was drawn per sample."""
    unit = preset("mems-mti1").draw(np.random.default_rng(5))
    st = SessionStream(dwell_s=1, rest_s=1, rng=5)
    assert np.array_equal(st.unit_model.acc.K, unit.acc.K) and np.array_equal(st.unit_model.gyr.bias, unit.gyr.bias)


def test_progress_of_the_blocks_on_a_terminal(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("optinav.core.progress.progress_enabled", lambda: True)
    argv = ["simulate", "accel-multipos", "--out", str(tmp_path / "s.csv"), "--dwell", "1", "--rest", "1"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    # the task's steps and the bar of the blocks (drawn at its start; nested, it is cleared when done)
    assert "simulate accel-multipos: " in err and "/1 [" in err and ", truth" in err


def test_first_order_sequences_kernel_is_the_recurrence_bit_for_bit():
    """The kernel of the Gauss–Markov and flicker sequences (a static record's 75 flicker sequences: half of it was
    branches and an index division per value): the recurrence b = φ·b₋₁ + σ√(1 − φ²)·w from a stationary start
    or a carried state, summed per group in column order, bit for bit, with φ constant or per sample."""
    from optinav.core.imu_model import _ar1_kernel

    rng = np.random.default_rng(6)
    n, k, groups = 40, 6, 3
    w, sigma = rng.normal(size=(n, k)), rng.uniform(0.5, 2.0, k)
    for phi in (np.exp(-1.0 / rng.uniform(1, 50, (1, k))), np.exp(-1.0 / rng.uniform(1, 50, (n, k)))):
        for fresh in (True, False):
            state0 = rng.normal(size=k)
            want, s = np.zeros((n, groups)), state0.copy()
            for i in range(n):
                p = phi[min(i, phi.shape[0] - 1)]
                for j in range(k):
                    if fresh and i == 0:
                        s[j] = sigma[j] * w[0, j]
                    else:
                        s[j] = p[j] * s[j] + sigma[j] * np.sqrt(1.0 - p[j] * p[j]) * w[i, j]
                    want[i, j // (k // groups)] += s[j]
            state = state0.copy()
            got = _ar1_kernel(w, np.ascontiguousarray(phi), sigma, state, fresh, groups)
            assert np.array_equal(got, want) and np.array_equal(state, s)
