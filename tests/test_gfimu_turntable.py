"""gfimu turntable calibration: simulation, the paper's closed form, the NLS default, identifiability."""

import numpy as np
import pytest

from optinav.core.results import Result
from optinav.errors import OptinavError
from optinav.gfimu import InstallationErrors, builtin, calibrate, closed_form, scheme_identifiability, simulate
from optinav.gfimu.turntable import MICRO_G, TurntableData, required_samples, turntable_truth


def _rel(est, truth):
    return np.abs((est - truth) / truth).reshape(-1, 5) * 100


def test_noise_free_both_methods_exact():
    arr = builtin()
    e = InstallationErrors.random(10, rng=1)
    d = simulate(arr, e, noise=1e-12, duration=0.05, rng=0)
    np.testing.assert_allclose(closed_form(arr, d).vector(), e.vector(), atol=1e-8)
    np.testing.assert_allclose(calibrate(arr, d, offset="zero", sigma=1e-12).estimate, e.vector(), atol=1e-9)
    for bad in (0.0, -1e-5):  # a wrong noise std would give a plausible result with a wrong std
        with pytest.raises(OptinavError, match="sigma must be positive"):
            calibrate(arr, d, sigma=bad)


def test_paper_setup_errors_and_crlb():
    arr = builtin()
    e = InstallationErrors.uniform(10)  # Δr = 1 mm, Δα = Δβ = 0.01 rad
    v = e.vector()
    d = simulate(arr, e, rates=(0.5, 1.0), duration=10.0, rng=4)  # 1000 samples per case
    res = calibrate(arr, d, offset="zero")  # simulated on the axis
    assert res.rank == 50 and list(res.samples_per_case) == [1000] * 6
    z = (res.estimate - v) / res.std
    assert np.abs(z).max() < 4.5  # consistent with the reported std (50 coefficients)
    assert _rel(res.estimate, v)[:, :3].max() < 1.0  # issue item 9 target at 0.5/1.0 rad/s
    # std from the data-estimated noise matches the CRLB at the true noise within the σ̂ scatter
    np.testing.assert_allclose(res.std, res.crlb_std, rtol=0.1)
    assert abs(np.mean(res.sigma) / MICRO_G - 1) < 0.05
    cf = closed_form(arr, d)
    assert _rel(cf.vector(), v)[:, 3:].max() < 0.02  # directions: tiny (paper 0.04 % with one sample)


def test_a_table_rate_error_is_stated_and_its_accuracy_goes_into_the_std():
    """A table rate 0.1 % off scales every centripetal term by 1.002, which the positions absorb (Δr_i ≈ 2e·r_i):
    converged, every gate passed, positions 68 std off. Not separable from the data: the result says
    so, and the rates' stated accuracy enters the std."""
    import dataclasses

    arr = builtin()
    e = InstallationErrors.uniform(10)
    d = simulate(arr, e, rates=(0.5, 1.0), duration=10.0, rng=4)
    off = dataclasses.replace(d, table_rate=d.table_rate * 1.001)
    exact = calibrate(arr, off, offset="zero")
    z = np.abs(exact.estimate - e.vector()) / exact.std
    assert z.max() > 20 and any("taken as exact" in s and "--rate-accuracy" in s for s in exact.statements)
    honest = calibrate(arr, off, offset="zero", rate_accuracy=1e-3)
    z = np.abs(honest.estimate - e.vector()) / honest.std
    assert z.max() < 4.5 and any("exact within 0.001" in s for s in honest.statements)
    np.testing.assert_allclose(honest.estimate, exact.estimate)  # the estimate is the same; only its std


def test_outputs_in_g_or_mg_and_the_wedge_in_degrees_are_named():
    """Outputs in g or mg and a wedge in degrees said 'check table_rate (--rate-unit deg/s) … give the centre's
    offset (--offset X,Y,Z, or estimate)': neither helps. The outputs' unit is the one optinav apply names."""
    import dataclasses

    arr = builtin()
    d = simulate(arr, InstallationErrors.uniform(10), rates=(0.5, 1.0), duration=1.0, rng=4)
    for scale, unit in ((1 / 9.80665, "g"), (1000 / 9.80665, "mg")):
        with pytest.raises(
            OptinavError, match=rf"the outputs look like {unit}, not m/s\^2; convert the f columns"
        ) as e:
            calibrate(arr, dataclasses.replace(d, acc=d.acc * scale))
        assert "--offset" not in str(e.value) and "--rate-unit" not in str(e.value)
    with pytest.raises(OptinavError, match=r"the wedge column reads 30, beyond π/2 rad: it is in degrees"):
        calibrate(arr, dataclasses.replace(d, gamma=np.degrees(d.gamma)))


def test_single_sample_closed_form_matches_paper_scale():
    """One sample per case (the paper's setting): position errors of order the paper's 12 % / 244 %."""
    arr = builtin()
    e = InstallationErrors.uniform(10)
    hi = np.mean(
        [
            _rel(closed_form(arr, simulate(arr, e, rates=(0.5, 1.0), duration=0.01, rng=k)).vector(), e.vector())[
                :, :3
            ].max()
            for k in range(20)
        ]
    )
    lo = np.mean(
        [
            _rel(closed_form(arr, simulate(arr, e, rates=(0.1, 0.2), duration=0.01, rng=k)).vector(), e.vector())[
                :, :3
            ].max()
            for k in range(20)
        ]
    )
    assert 4 < hi < 40 and 100 < lo < 1000
    assert 15 < lo / hi < 35  # ∝ 1/(w2² − w1²): 0.75/0.03 = 25


def test_required_samples_from_crlb():
    arr = builtin()
    e = InstallationErrors.uniform(10)
    n_hi = required_samples(arr, e, rates=(0.5, 1.0), target_pct=1.0)
    n_lo = required_samples(arr, e, rates=(0.1, 0.2), target_pct=20.0)
    assert 50 < n_hi < 1000 and 50 < n_lo < 1000  # so 1000 samples per case meet both targets


def test_scheme_identifiability():
    arr = builtin()
    assert scheme_identifiability(arr).rank == 50
    assert scheme_identifiability(arr, gamma=0.0).rank < 50  # no wedge
    assert scheme_identifiability(arr, mountings=(1,)).rank == 20  # one mounting: 2 per sensor
    assert scheme_identifiability(arr, rates=(1.0,)).rank == 30  # one rate: 3 per sensor
    rep = scheme_identifiability(arr, bias_scale=True)  # 7 unknowns, 6 cases per sensor
    assert rep.rank == 60 and rep.n_params == 70
    rep = scheme_identifiability(arr, offset=True)
    assert rep.n_params - rep.rank == 6


def test_offset_known_estimate_and_gauge():
    arr = builtin()
    e = InstallationErrors.random(10, rng=3)
    off = [0.01, 0.02, -0.005]
    d = simulate(arr, e, offset=off, rng=2)
    with pytest.raises(OptinavError, match="cannot be separated"):
        calibrate(arr, d, offset="estimate")
    res = calibrate(arr, d, offset=off)
    assert np.abs((res.estimate - e.vector()) / res.std).max() < 4.5
    # not given, the offset is a common shift of all positions the data cannot tell from mean(Δr): given as zero
    # (the paper's assumption) every Δr is off by it, thousands of std (the tester's 2 cm: 33 000σ) ...
    assumed = calibrate(arr, d, offset="zero")
    np.testing.assert_allclose(assumed.dr - e.dr, np.broadcast_to(off, e.dr.shape), atol=2e-4)
    assert any("shifts every dr" in s for s in assumed.statements)
    # ... so by default (unknown) Δr are reported relative to their mean, within their std of the truth's, and
    # the absolute Δr are not observable
    res0 = calibrate(arr, d)
    truth = turntable_truth(e)
    cmp = truth.compare(res0)
    assert len(cmp) == 50 and max(float(c["z"]) for c in cmp.values()) < 4.5
    assert "dr_x_1 - mean(dr_x)" in cmp and "dr_x_1" not in cmp
    pars = res0.parameters()
    assert not pars["dr_x_1"].observable and "--offset" in pars["mean(dr_x)"].reason
    np.testing.assert_allclose(res0.common_shift_m, e.dr.mean(axis=0) + off, atol=5e-5)
    np.testing.assert_allclose(res0.dr.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(res0.dr, res.dr - res.dr.mean(axis=0), atol=5e-5)  # = the known-offset fit's
    # the common shift does not change the compensated rate solution (ω, ω̇); the repo's solver on a coning motion
    from optinav.gfimu.errors import coning_motion, perturb
    from optinav.gfimu.solve import solve_motion

    mo = coning_motion(duration=5.0)
    f = perturb(arr, e).outputs(mo.A, mo.wdot, mo.omega)
    known, gauged = (solve_motion(r.calibrated_array(), f, mo.t, mo.omega[0]) for r in (res, res0))
    assert np.abs(gauged.omega - known.omega).max() < 1e-3 * np.abs(mo.omega).max()
    assert np.abs(gauged.omega - mo.omega).max() < 2 * np.abs(known.omega - mo.omega).max() + 1e-9


def test_result_json_and_data_files(tmp_path):
    arr = builtin()
    d = simulate(arr, InstallationErrors.random(10, rng=5), duration=1.0, rng=6)
    res = calibrate(arr, d)
    p = tmp_path / "r.json"
    res.to_json(p)
    back = Result.from_json(p)
    np.testing.assert_allclose(back.estimate, res.estimate)
    for suf in (".npz", ".csv"):
        d.save(tmp_path / f"d{suf}")
        d2 = TurntableData.load(tmp_path / f"d{suf}", 10)
        np.testing.assert_allclose(d2.acc, d.acc, rtol=1e-11)
        assert list(d2.case) == list(d.case) and d2.gamma == pytest.approx(d.gamma)
    with pytest.raises(OptinavError, match="6 accelerometer|configuration"):
        calibrate(builtin().with_geometry(arr.positions[:6], arr.directions[:6]), d)


# --- the simulator in blocks (TurntableStream): bounded memory, the same rows whatever the block length -----------


def _stream(**kw):
    from optinav.gfimu.turntable import TurntableStream

    arr = builtin()
    args = dict(rates=(0.5, 1.0), mountings=(1, 2, 3), duration=3.0, rng=11, offset=[0.002, -0.001, 0.0])
    return TurntableStream(arr, InstallationErrors.random(10, rng=5), **{**args, **kw})


def test_stream_rows_do_not_depend_on_the_block_length():
    whole = _stream().gather()
    n = len(whole.t)
    assert n == 1800 and list(whole.case) == [k for k in range(1, 7) for _ in range(300)]
    for rows in (1, 7, 299, 300, 301, 1024, 10**6):
        s = _stream()
        assert s.n == n and s.n_blocks(rows) == -(-n // rows)
        blocks = list(s.blocks(rows))
        assert len(blocks) == s.n_blocks(rows)
        d = s.gather(iter(blocks))
        for a, b in (
            (d.t, whole.t),
            (d.acc, whole.acc),
            (d.mounting, whole.mounting),
            (d.table_rate, whole.table_rate),
        ):
            np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(np.concatenate([b[2] for b in blocks]), whole.case)
    # another seed gives other noise on the same noise-free outputs
    other = _stream(rng=12).gather()
    assert not np.array_equal(other.acc, whole.acc)
    np.testing.assert_allclose(other.acc, whole.acc, atol=10 * MICRO_G)


def test_simulate_is_the_stream_gathered():
    from optinav.gfimu.turntable import model_outputs

    arr = builtin()
    e = InstallationErrors.random(10, rng=5)
    d = simulate(arr, e, duration=3.0, rng=11, offset=[0.002, -0.001, 0.0])
    g = _stream().gather()
    for a, b in (
        (d.t, g.t),
        (d.acc, g.acc),
        (d.mounting, g.mounting),
        (d.table_rate, g.table_rate),
        (d.sigma, g.sigma),
    ):
        np.testing.assert_array_equal(a, b)
    assert (d.gamma, d.gravity) == (g.gamma, g.gravity)
    # times back to back at the sample rate; the noise white, 1 µg, around the model's outputs
    np.testing.assert_allclose(np.diff(d.t), 0.01, rtol=1e-9)
    from optinav.gfimu.errors import perturb

    act = perturb(arr, e)
    u = np.radians(30.0)
    f0 = model_outputs(
        act.positions, act.directions, np.array([np.sin(u), 0, np.cos(u)]), 0.5, d.gravity, [0.002, -0.001, 0.0]
    )
    z = (d.acc[:300] - f0) / MICRO_G
    assert abs(z.std() - 1) < 0.05 and abs(z.mean()) < 0.1
    assert abs(np.corrcoef(z[:-1].ravel(), z[1:].ravel())[0, 1]) < 0.1
    with pytest.raises(OptinavError, match="rows"):
        _stream().gather(list(_stream().blocks(500))[:-1])


def test_case_labels_follow_the_order_of_appearance():
    from optinav.gfimu.turntable import case_labels

    d = simulate(builtin(), mountings=(3, 1, 3), rates=(1.0, 0.5), duration=0.02, rng=0)
    assert list(d.mounting) == [3, 3, 3, 3, 1, 1, 1, 1, 3, 3, 3, 3]
    assert list(d.case) == [1, 1, 2, 2, 3, 3, 4, 4, 1, 1, 2, 2]
    assert list(case_labels([2, 2, 1, 2], [0.5, 0.5 + 1e-14, 0.5, 0.5])) == [1, 1, 2, 1]
    assert case_labels([], []).shape == (0,)


def test_streamed_csv_is_the_saved_file(tmp_path):
    from optinav.gfimu.turntable import turntable_csv_writer

    s = _stream(mountings=(1, 2, 3, 1), gamma=np.radians(25.0), gravity=9.79)
    d = _stream(mountings=(1, 2, 3, 1), gamma=np.radians(25.0), gravity=9.79).gather()
    d.save(tmp_path / "whole.csv")
    with turntable_csv_writer(tmp_path / "blocks.csv", 10, s.gamma, s.gravity) as write:
        for block in s.blocks(333):
            write(*block)
    whole = (tmp_path / "whole.csv").read_bytes()
    assert (tmp_path / "blocks.csv").read_bytes() == whole
    lines = whole.decode().splitlines()
    assert lines[0] == "t,f1,f2,f3,f4,f5,f6,f7,f8,f9,f10,case,mounting,table_rate,wedge,gravity"
    assert len(lines) == 1 + 2400 and lines[-1].split(",")[11:14] == ["2", "1", "1"]  # mounting 1 again: cases 1, 2
    back = TurntableData.load(tmp_path / "blocks.csv", 10)
    np.testing.assert_allclose(back.acc, d.acc, rtol=1e-11)
    np.testing.assert_allclose(back.t, d.t, rtol=1e-11)
    assert list(back.case) == list(d.case) and back.gamma == pytest.approx(d.gamma) and back.gravity == 9.79
    # an error inside the block leaves no file
    with pytest.raises(RuntimeError), turntable_csv_writer(tmp_path / "x.csv", 10, s.gamma) as write:
        write(*next(_stream().blocks(10)))
        raise RuntimeError("stop")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocks.csv", "whole.csv"]


def test_cases_summarized_while_reading_in_blocks(tmp_path, monkeypatch):
    """Calibration reads a long log block by block into per-case means and the pooled within-case std (pairwise
    merges across blocks): the summary and the fit equal those of the whole log in memory."""
    from optinav.gfimu.turntable import case_means, read_cases

    arr = builtin("cylinder10")
    e = InstallationErrors.random(arr.n, rng=3)
    d = simulate(arr, e, rates=(0.5, 1.0), duration=1.0, noise=1e-4, rng=5)
    path = d.save(tmp_path / "tt.csv")
    monkeypatch.setattr("optinav.io.readers.CHUNK_ROWS", 37)  # every case spans several blocks
    got = read_cases(path, arr.n)
    whole = case_means(TurntableData.load(path, arr.n))
    assert got.samples == len(d.t) and got.n_outputs == arr.n and got.gamma == pytest.approx(d.gamma)
    assert np.array_equal(got.cases.count, whole.count) and np.array_equal(got.cases.mounting, whole.mounting)
    np.testing.assert_allclose(got.cases.rate, whole.rate, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.cases.mean, whole.mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.cases.sigma, whole.sigma, rtol=1e-9)
    np.testing.assert_allclose(got.cases.sigma, 1e-4, rtol=0.05)  # the simulated noise
    a, b = calibrate(arr, got), calibrate(arr, TurntableData.load(path, arr.n))
    np.testing.assert_allclose(a.estimate, b.estimate, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.std, b.std, rtol=1e-6)
    with pytest.raises(OptinavError, match="accelerometer columns"):
        read_cases(path, arr.n + 1)


def test_gravity_column_in_g_or_mg_is_named_before_the_fit():
    """A gravity column in g (1.0) said 'the LM fit did not converge; try --method closed-form', which was refused
    too: the column's unit is named before the fit, with either method."""
    import dataclasses

    arr = builtin()
    d = simulate(arr, InstallationErrors.uniform(10), rates=(0.5, 1.0), duration=1.0, rng=4)
    for g, unit in ((1.0, "g"), (1000.0, "mg")):
        for method in ("lm", "closed-form"):
            with pytest.raises(OptinavError, match=rf"the gravity column reads {g:g}: it is in {unit}, not m/s\^2"):
                calibrate(arr, dataclasses.replace(d, gravity=g), method=method, offset="zero")


def test_nan_in_a_column_names_the_column_and_its_first_rows(tmp_path, monkeypatch):
    """NaN in table_rate said 'J contains 250 NaN or infinite value(s)' (an internal name): every column of the
    log is checked when read, block by block, and the message names the column and its first data rows."""
    from optinav.gfimu.turntable import read_cases

    arr = builtin("cylinder10")
    d = simulate(arr, InstallationErrors.random(arr.n, rng=3), rates=(0.5, 1.0), duration=1.0, rng=5)
    path = d.save(tmp_path / "tt.npz")
    base = dict(np.load(path))
    monkeypatch.setattr("optinav.io.readers.CHUNK_ROWS", 37)
    for col in ("t", "case", "mounting", "table_rate", "wedge", "gravity"):
        x = {k: v.copy() for k, v in base.items()}
        x[col][100:105] = np.nan
        np.savez(tmp_path / "bad.npz", **x)
        with pytest.raises(OptinavError, match=rf"the {col} column holds NaN/inf in 5 row\(s\) \(data rows 101, 102"):
            read_cases(tmp_path / "bad.npz", arr.n)
    x = {k: v.copy() for k, v in base.items()}
    x["f"][60, 2] = np.inf
    np.savez(tmp_path / "bad.npz", **x)
    with pytest.raises(OptinavError, match=r"output 3 of the f array holds NaN/inf in 1 row\(s\) \(data row 61,"):
        read_cases(tmp_path / "bad.npz", arr.n)
    rate = d.table_rate.copy()
    rate[7] = np.nan
    import dataclasses

    with pytest.raises(OptinavError, match=r"the table_rate column holds NaN/inf in 1 row\(s\) \(data row 8,"):
        calibrate(arr, dataclasses.replace(d, table_rate=rate))


def test_swapped_rate_labels_are_told_from_negated_outputs():
    """Rate labels swapped (the case at the higher rate labelled with the lower) said 'the outputs look negated;
    negate the f columns', which is refused again: swapped labels reverse only the change between the rates,
    negated outputs gravity's part of the case means too. Each message names its cause; its remedy is accepted."""
    import dataclasses

    arr = builtin()
    d = simulate(arr, InstallationErrors.uniform(10), rates=(0.5, 1.0), duration=1.0, rng=4)
    swapped = dataclasses.replace(d, table_rate=np.where(np.isclose(d.table_rate, 0.5), 1.0, 0.5))
    with pytest.raises(OptinavError, match=r"the table-rate labels look swapped") as e:
        calibrate(arr, swapped)
    assert "negate" not in str(e.value)
    with pytest.raises(OptinavError, match=r"the outputs look negated") as e:
        calibrate(arr, dataclasses.replace(d, acc=-d.acc))
    assert "swapped" not in str(e.value)
    calibrate(arr, d)  # what either remedy gives back


def test_a_sign_inverted_or_swapped_output_column_is_named():
    """One sensor's sign inverted said 'the table rates disagree … rates 0.849× the stated ones; check table_rate,
    --rate-unit, --offset' (f7) or 'direction errors up to 3.13 rad' (f3), two swapped columns the same rate
    message: none of them the cause. Gravity dominates every case mean, so a column that does not read its
    sensor (while the others do) is named with what it reads, whatever the rates."""
    import dataclasses

    arr = builtin()
    d = simulate(arr, InstallationErrors.random(10, rng=2), rates=(0.5, 1.0), duration=1.0, rng=4)
    for k in (2, 6):  # an axial sensor (f3) and one whose flip moved the rate check (f7)
        acc = d.acc.copy()
        acc[:, k] *= -1
        with pytest.raises(OptinavError, match=rf"f{k + 1} reads the negative of accelerometer {k + 1}") as e:
            calibrate(arr, dataclasses.replace(d, acc=acc))
        assert "--rate-unit" not in str(e.value) and "negate a sensor" in str(e.value)
    with pytest.raises(OptinavError, match=r"f3 and f4 read each other's accelerometers \(swapped\)"):
        calibrate(arr, dataclasses.replace(d, acc=d.acc[:, [0, 1, 3, 2, 4, 5, 6, 7, 8, 9]]))
    # rates 20 % off are not a column's fault: their own message
    with pytest.raises(OptinavError, match=r"the table rates disagree"):
        calibrate(arr, dataclasses.replace(d, table_rate=d.table_rate * 1.2), offset="zero")
    calibrate(arr, d)


def test_rates_in_rad_s_read_as_deg_s_are_named():
    """--rate-unit deg/s on a table_rate column in rad/s predicts almost no centripetal change, so the rate check
    was skipped and the fit ended in 'implausible installation errors (|dr| up to 135 m) … check table_rate and
    the units', not naming the flag given in error. The measured change is far above the noise: named."""
    import dataclasses

    arr = builtin()
    d = simulate(arr, InstallationErrors.uniform(10), rates=(0.5, 1.0), duration=1.0, rng=4)
    for method in ("lm", "closed-form"):
        with pytest.raises(OptinavError, match=r"rates look like rad/s read as deg/s.*drop --rate-unit deg/s"):
            calibrate(arr, dataclasses.replace(d, table_rate=np.radians(d.table_rate)), method=method)


def test_a_noise_std_far_above_the_outputs_noise_is_refused():
    """--noise 1e-3 on 1 µg data gave exit 0 with every std 100× too large (z 0.03 against the truth): the fit's
    reduced χ² against it, 1e-4, is what 10 degrees of freedom give far less than once in 1e6. A noise within a few
    times the true one is kept (its std stay conservative)."""
    arr = builtin()
    e = InstallationErrors.uniform(10)
    d = simulate(arr, e, rates=(0.5, 1.0), duration=2.0, rng=4)
    for sigma in (1e-3, 3e-4):
        for method in ("lm", "closed-form"):
            with pytest.raises(OptinavError, match=r"--noise is larger than the noise of the outputs.*check --noise"):
                calibrate(arr, d, sigma=sigma, method=method)
    res = calibrate(arr, d, sigma=2 * MICRO_G, offset="zero")
    assert np.abs((res.estimate - e.vector()) / res.std).max() < 4.5


def test_a_turntable_column_named_with_its_unit_is_named(tmp_path):
    """'table_rate_deg', 'table_rate [deg/s]' or 'wedge_deg' said 'has no table_rate (found: …); write it with
    optinav simulate gfimu-turntable': the column is there under its unit's name, and for a rate in deg/s the
    flag that reads it is --rate-unit deg/s. The message names the column and the remedy."""
    from optinav.gfimu.turntable import read_cases

    arr = builtin()
    d = simulate(arr, InstallationErrors.uniform(10), rates=(0.5, 1.0), duration=0.2, rng=4)
    path = d.save(tmp_path / "tt.csv")
    text = path.read_text()
    for old, new, why in (
        ("table_rate", "table_rate_deg", r"'table_rate_deg' \(in deg\).*name it table_rate.*--rate-unit deg/s"),
        ("table_rate", "table_rate [deg/s]", r"'table_rate \[deg/s\]' \(in deg/s\).*--rate-unit deg/s"),
        ("wedge", "wedge_deg", r"names its wedge column 'wedge_deg' \(in deg\).*name it wedge, in rad"),
    ):
        bad = tmp_path / "named.csv"
        head, rest = text.split("\n", 1)
        bad.write_text(head.replace(old, new) + "\n" + rest)
        with pytest.raises(OptinavError, match=why):
            read_cases(bad, arr.n)


def test_swapped_mounting_labels_a_wrong_wedge_or_gravity_column_are_named():
    """Mounting labels 2 and 3 swapped said 'the table rates disagree … rates 0.638× the stated ones'; a wedge
    column of 45° on a 30° wedge said 'implausible installation errors (|dr| up to 4.78 m)', of 0° the same with a
    numpy divide-by-zero warning; a gravity column 6e-5 off (9.806) said 'check --noise, the configuration and
    --offset'; mounting 0 printed '[np.int64(0), …]'. The outputs extrapolated to rate 0 are gravity alone, so
    the table axis they see is compared with the labelled one before the fit, and the gates name gravity."""
    import dataclasses
    import warnings

    arr = builtin()
    d = simulate(arr, InstallationErrors.random(10, rng=2), rates=(0.5, 1.0), duration=1.0, rng=4)
    swapped = dataclasses.replace(d, mounting=np.array([1, 3, 2])[d.mounting - 1])
    with pytest.raises(OptinavError, match=r"labelled mounting 2 see the table axis of mounting 3.*give those rows"):
        calibrate(arr, swapped)
    for wedge in (45.0, 0.0):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(OptinavError, match=rf"the wedge column says {wedge:g}°.*a wedge of (29|30)\.\d+°"):
                calibrate(arr, dataclasses.replace(d, gamma=np.radians(wedge)))
    with pytest.raises(OptinavError, match=r"the gravity column \(the local gravity"):
        calibrate(arr, dataclasses.replace(d, gravity=9.806))
    with pytest.raises(OptinavError, match=r"mounting\(s\) 0 are not among 1, 2, 3"):
        calibrate(arr, dataclasses.replace(d, mounting=d.mounting - 1))


def test_configuration_positions_in_mm_or_cm_are_named():
    """A CONFIG.json with the positions in mm (40 for 0.04 m) said 'the table rates disagree … rates 0.0315× the
    stated ones; check table_rate (--rate-unit deg/s), --offset': the centripetal terms scale with the positions,
    so a change 1e-3 (1e-2) of the predicted one names the configuration's unit."""
    import dataclasses

    arr = builtin()
    d = simulate(arr, InstallationErrors.uniform(10), rates=(0.5, 1.0), duration=1.0, rng=4)
    for unit, k in (("mm", 1e3), ("cm", 1e2)):
        scaled = arr.with_geometry(np.asarray(arr.positions) * k, arr.directions)
        with pytest.raises(OptinavError, match=rf"they look like {unit}, not m; write the positions .* in m"):
            calibrate(scaled, d)
    # rates in rpm scale it by (2π/60)² = 0.011, 10 % from cm: told apart
    with pytest.raises(OptinavError, match=r"table_rate column looks like rpm.*convert the table_rate column"):
        calibrate(arr, dataclasses.replace(d, table_rate=d.table_rate * 60 / (2 * np.pi)))


def test_output_columns_numbered_padded_or_with_a_unit_are_read(tmp_path):
    """Outputs f0..f9 said 'has 9 accelerometer columns, the configuration 10' (the file has ten); f01..f10 and
    'f1 [g]' / f1_mg said 'has no accelerometer outputs f1..fN'. Zero-padded numbers and a unit in g, mg or µg
    in the names are read (converted to m/s²); numbering from 0 is named."""
    from optinav.gfimu.turntable import read_cases

    arr = builtin()
    d = simulate(arr, InstallationErrors.uniform(10), rates=(0.5, 1.0), duration=0.2, rng=4)
    path = d.save(tmp_path / "tt.csv")
    ref = read_cases(path, arr.n).cases.mean
    head, rest = path.read_text().split("\n", 1)
    rows = np.loadtxt(path, delimiter=",", skiprows=1)
    names = head.split(",")
    f_cols = [j for j, n in enumerate(names) if n.startswith("f")]
    for pattern, scale in (("f{:02d}", 1.0), ("f{} [g]", 1 / 9.80665), ("f{}_mg", 1000 / 9.80665)):
        x = rows.copy()
        x[:, f_cols] *= scale
        hdr = [pattern.format(int(n[1:])) if j in f_cols else n for j, n in enumerate(names)]
        np.savetxt(tmp_path / "named.csv", x, delimiter=",", header=",".join(hdr), comments="", fmt="%.17g")
        np.testing.assert_allclose(read_cases(tmp_path / "named.csv", arr.n).cases.mean, ref, rtol=1e-12)
    (tmp_path / "zero.csv").write_text(
        ",".join(f"f{int(n[1:]) - 1}" if n.startswith("f") else n for n in names) + "\n" + rest
    )
    with pytest.raises(OptinavError, match=r"numbers its outputs from f0.*rename the output columns f1, f2"):
        read_cases(tmp_path / "zero.csv", arr.n)
