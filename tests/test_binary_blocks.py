"""Binary files read in row blocks (optinav.io.arrayblocks, optinav.io.parquet.iter_parquet): each name's blocks
join to exactly what the whole-file reader returns, and iter_imu's blocks to read_imu's log, errors included."""

from pathlib import Path

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import scipy.io
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from optinav.errors import OptinavError
from optinav.io import iter_imu, read_imu
from optinav.io.arrayblocks import block_bounds
from optinav.io.readers import iter_table, load_table
from test_io import _mutate, _valid, _write_mat73

N = 203


def _columns(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    return np.arange(n) / 100.0, rng.normal(size=(n, 3)), rng.normal(size=(n, 3))


def _files(d: Path, n: int = N) -> dict[str, Path]:
    """One file of every layout the block readers handle, each with something beside the samples."""
    t, acc, gyr = _columns(n)
    lab = np.array(["a", "bb"] * (n // 2) + ["c"] * (n % 2))
    rec = np.zeros(n, dtype=[("t", float), ("ax", float), ("ay", np.float32), ("az", np.int16)])
    rec["t"], rec["ax"], rec["ay"], rec["az"] = t, acc[:, 0], acc[:, 1], np.arange(n)
    names = ("a.npz", "z.npz", "c.npy", "f.npy", "r.npy", "e.h5", "m.mat", "m2.mat", "p.parquet", "v5.mat", "v5z.mat")
    out = {k: d / k for k in names}
    np.savez(out["a.npz"], t=t, acc=acc, gyro=gyr, M=np.eye(3), rate=100.0, label=lab, acc_unit="g")
    np.savez_compressed(out["z.npz"], t=t, acc=acc, gyro=np.asfortranarray(gyr), M=np.eye(3), row=t[None, :])
    np.save(out["c.npy"], np.column_stack([t, acc, gyr]))
    np.save(out["f.npy"], np.asfortranarray(np.column_stack([t, acc, gyr])))
    np.save(out["r.npy"], rec)
    with h5py.File(out["e.h5"], "w") as f:
        f["imu/t"], f["imu/acc"], f["M"], f["row"], f["col"] = t, acc, np.eye(3), t[None, :], t[:, None]
        f.create_dataset("imu/gyro", data=gyr, chunks=(16, 3), compression="gzip")
        f["lab"] = np.array([b"x", b"yy"] * (n // 2) + [b"z"] * (n % 2))
        f.create_dataset("comp", data=rec, chunks=True)
        f.attrs["rate"], f["imu/acc"].attrs["unit"] = 100.0, "g"
        f["slow"] = np.arange(n // 3 * 2.0)  # another rate: whole in the first block
    labels = ["x", "yy", "zzz"] * (n // 3) + ["w"] * (n % 3)
    _write_mat73(out["m.mat"], {"t": t, "acc": acc, "acc_unit": "g", "labels": labels, "M": np.eye(3), "note": "ab"})
    _write_mat73(out["m2.mat"], {"data": np.column_stack([t, acc])})
    table = pa.table(
        {
            "t": t,
            "v": acc[:, 0],
            "s": lab,
            "lst": pa.array(list(acc), type=pa.list_(pa.float64(), 3)),
            "st": pa.array([{"x": float(v), "y": 1.0} for v in t]),
        }
    )
    pq.write_table(table, out["p.parquet"], row_group_size=37)
    v5 = {
        "t": t[:, None],
        "acc": acc,
        "gyro": gyr.astype(np.float32),
        "counts": np.arange(n, dtype=np.int16)[None, :],
        "moving": (np.arange(n) % 3 == 0)[:, None],
        "M": np.eye(3),
        "acc_unit": "g",
        "info": {"rate": 100.0, "who": "x"},
        "labels": np.array(["a", "b"] * (n // 2) + ["c"] * (n % 2), dtype=object)[:, None],
        "cube": np.zeros((2, 2, 2)),
    }
    scipy.io.savemat(out["v5.mat"], v5)
    scipy.io.savemat(out["v5z.mat"], v5, do_compression=True)
    return out


def _joined(path: Path, chunk: int, **kw):
    blocks = list(iter_table(path, chunk_rows=chunk, **kw))
    parts: dict[str, list] = {}
    for b in blocks:
        for k, v in b.data.items():
            parts.setdefault(k, []).append(v)
    return blocks, {k: np.concatenate(v) for k, v in parts.items()}


def _same_as_whole(path: Path, chunk: int, **kw) -> list:
    whole = load_table(path, **kw)
    blocks, joined = _joined(path, chunk, **kw)
    assert list(joined) == list(whole.data)
    for k, v in joined.items():
        assert v.dtype == whole.data[k].dtype and np.array_equal(v, whole.data[k], equal_nan=v.dtype.kind == "f"), k
    for b in blocks:
        assert (b.meta, b.units, b.skipped, b.table) == (whole.meta, whole.units, whole.skipped, whole.table)
    key = next(k for k in whole.data if k not in blocks[0].fixed)
    assert [b.row0 for b in blocks] == list(np.cumsum([0] + [len(b.data[key]) for b in blocks]))[:-1]
    return blocks


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return _files(tmp_path_factory.mktemp("blocks"))


@pytest.fixture(autouse=True)
def _stream_small_matlab_matrices(monkeypatch):
    """MATLAB v5 matrices are read by rows from 1 MiB of data on: from any size here, so that small files test it."""
    import optinav.io.arrayblocks

    monkeypatch.setattr(optinav.io.arrayblocks, "_MAT_STREAM_BYTES", 1)


@pytest.mark.parametrize("name", ["a.npz", "z.npz", "c.npy", "f.npy", "r.npy", "e.h5", "m.mat", "m2.mat", "p.parquet"])
@pytest.mark.parametrize("chunk", [1, 2, 7, 101, N - 1, N, 10_000])
def test_blocks_join_to_the_whole_file(files, name, chunk):
    blocks = _same_as_whole(files[name], chunk)
    assert len(blocks) == (1 if chunk >= N else len(block_bounds(N, chunk))) and len(block_bounds(N, 7)) == 29
    assert all(len(b.data[next(k for k in b.data if k not in b.fixed)]) <= max(chunk, 3) for b in blocks)
    if len(blocks) > 1 and name in ("a.npz", "z.npz", "e.h5", "m.mat", "v5.mat", "v5z.mat"):
        assert "M" in blocks[0].fixed and blocks[1].data["M"].shape == (0, 3)  # whole once, then empty


@pytest.mark.parametrize("name", ["c.npy", "f.npy", "m2.mat"])
def test_positional_names_of_a_single_matrix(files, name):
    blocks = _same_as_whole(
        files[name], 50, names=["t", "ax", "_", "az"] + (["gx", "gy", "gz"] if "npy" in name else [])
    )
    assert "ay" not in blocks[0].data and blocks[0].table is not None


def test_hdf5_datasets_by_path(files):
    blocks = _same_as_whole(files["e.h5"], 50, only=["imu/t", "imu/gyro", "M"])
    assert list(blocks[0].data) == ["imu/t", "imu/gyro", "M"] and len(blocks) == 5


@pytest.mark.parametrize("n", [2, 3, 4, 5, 10, 11, 100, 101])
@pytest.mark.parametrize("chunk", [1, 2, 3, 4, 10])
def test_block_bounds(n, chunk):
    b = block_bounds(n, chunk)
    assert b[0][0] == 0 and b[-1][1] == n and all(x[1] == y[0] for x, y in zip(b, b[1:]))
    sizes = [y - x for x, y in b]
    assert min(sizes) >= 2 and max(sizes) <= max(chunk, 2) + (1 if chunk <= 2 else 0)
    if chunk >= 3:
        assert max(sizes) <= chunk


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    n=st.integers(2, 80),
    chunk=st.integers(1, 30),
    kind=st.sampled_from(["npz", "npz-deflated", "npy-fortran", "h5-chunked", "parquet"]),
)
def test_any_length_and_block_size_joins_to_the_whole(tmp_path, n, chunk, kind):
    t, acc, _ = _columns(n, seed=n)
    path = tmp_path / f"x.{kind.split('-')[0]}"
    if kind == "npz":
        np.savez(path, t=t, acc=acc, k=np.ones(2))
    elif kind == "npz-deflated":
        np.savez_compressed(path, t=t, acc=np.asfortranarray(acc))
    elif kind == "npy-fortran":
        np.save(path, np.asfortranarray(np.column_stack([t, acc])))
    elif kind == "h5-chunked":
        with h5py.File(path, "w") as f:
            f.create_dataset("t", data=t, chunks=(min(n, 3),))
            f["acc"], f["k"] = acc, np.ones(5)
    else:
        pq.write_table(pa.table({"t": t, "ax": acc[:, 0]}), path, row_group_size=max(1, n // 3))
    _same_as_whole(path, chunk)


_IMU_COLUMNS = {
    "c.npy": {"columns": "t,ax,ay,az,gx,gy,gz"},
    "e.h5": {"columns": "t=imu/t,acc=imu/acc,gyro=imu/gyro"},
    "p.parquet": {"columns": "t=t,acc=lst"},
}


@pytest.mark.parametrize("name", ["a.npz", "z.npz", "e.h5", "m.mat", "p.parquet", "c.npy", "v5.mat", "v5z.mat"])
def test_iter_imu_of_a_binary_file_is_read_imu_in_blocks(files, name):
    kw = _IMU_COLUMNS.get(name, {})
    whole = read_imu(files[name], **kw)
    chunks = iter_imu(files[name], chunk_rows=20, **kw)
    logs = list(chunks)
    assert len(logs) == 11 and all(len(x) <= 20 for x in logs)
    # a MATLAB v5 cell of labels is read whole only: the file is then read whole (chunks.table stays None)
    assert (chunks.table is None) == name.startswith("v5")
    for attr in ("t", "acc", "gyr"):
        a = [getattr(x, attr) for x in logs]
        assert (a[0] is None and getattr(whole, attr) is None) or np.array_equal(
            np.concatenate(a), getattr(whole, attr)
        )
    assert logs[0].notes == whole.notes and logs[0].acc_input_unit == whole.acc_input_unit
    assert chunks.position == chunks.size and chunks.rows == N


def test_iter_imu_reads_whole_when_a_used_array_is_of_another_length(tmp_path):
    t, acc, gyr = _columns(N)
    np.savez(tmp_path / "bad.npz", t=t[:100], acc=acc, gyro=gyr)  # the samples are acc/gyro, t is shorter
    with pytest.raises(OptinavError) as whole:
        read_imu(tmp_path / "bad.npz")
    with pytest.raises(OptinavError) as blocks:
        list(iter_imu(tmp_path / "bad.npz", chunk_rows=20))
    assert str(blocks.value) == str(whole.value) and "t: 100, acc: 203" in str(whole.value)
    # the samples are the minority: the big unrelated array sets the blocks, the log is still read once
    np.savez(tmp_path / "small.npz", t=t[:5], acc=acc[:5], gyro=gyr[:5], image=np.zeros(5000))
    logs = list(iter_imu(tmp_path / "small.npz", chunk_rows=20))
    assert np.array_equal(np.concatenate([x.t for x in logs]), t[:5])


def test_a_damaged_member_is_a_one_line_error(tmp_path):
    t, acc, gyr = _columns(5000)
    path = tmp_path / "x.npz"
    np.savez(path, t=t, acc=acc, gyro=gyr)
    raw = bytearray(path.read_bytes())
    i = raw.index(b"gyro.npy") + 80_000  # inside gyro's data: its CRC fails when the member is read to its end
    raw[i : i + 8] = b"\xff" * 8
    path.write_bytes(bytes(raw))
    with pytest.raises(OptinavError) as exc:
        list(iter_table(path, chunk_rows=1000))
    assert "\n" not in str(exc.value) and "x.npz" in str(exc.value)


def _labels_cell(path: Path, k: int) -> tuple[bytearray, str, int]:
    """(the bytes of the MATLAB v5 file ``path``, its byte order, the offset of cell ``k`` of its ``labels``)."""
    import struct

    from optinav.io.arrayblocks import _mat5_endian, _matrix_head, _variables

    raw = bytearray(path.read_bytes())
    with open(path, "rb") as fh:
        e = _mat5_endian(fh.read(128))
        pos, head = next((p, h) for p, _, _, h in _variables(fh, e, len(raw), 1 << 20) if b"labels" in h[:64])
    off = pos + _matrix_head(head, e).data
    for _ in range(k):
        off += 8 + struct.unpack_from(e + "I", raw, off + 4)[0]
    return raw, e, off


def test_a_damaged_element_inside_a_matlab_cell_array_is_a_one_line_error(files, tmp_path):
    # found by the fuzz test on Hypothesis seed 17: an element tag missing inside the cell array `labels` (its
    # header intact) crashed scipy.io.loadmat's compiled reader (segmentation fault); the elements of cell and
    # struct arrays are now checked inside their parent before scipy reads the file
    from optinav.io.arrayblocks import _matrix_head

    raw, e, off = _labels_cell(files["v5.mat"], 33)  # the 34th cell
    cut = off + _matrix_head(bytes(raw[off : off + 256]), e).data  # that cell's character data element
    del raw[cut : cut + 8]
    path = tmp_path / "cut.mat"
    path.write_bytes(bytes(raw))
    reads = (lambda: read_imu(path), lambda: list(iter_imu(path, chunk_rows=30)), lambda: list(iter_table(path)))
    for read in reads:
        with pytest.raises(OptinavError, match="variable at byte .*: element 33") as exc:
            read()
        assert "\n" not in str(exc.value)


def test_a_char_array_marked_sparse_is_a_one_line_error(files, tmp_path):
    # found by a fork-per-file fuzz: one byte turning a cell's char array into a sparse one (class 5) crashed
    # scipy.io.loadmat; a sparse array's indices and values are checked against its dimensions first
    import scipy.io
    import scipy.sparse

    raw, _, off = _labels_cell(files["v5.mat"], 14)
    assert raw[off + 16] == 4  # the 15th cell: a char array (class 4) ...
    raw[off + 16] = 5  # ... marked sparse
    path = tmp_path / "sparse.mat"
    path.write_bytes(bytes(raw))
    # the whole reader and the block reader (which reads a cell array's variable through scipy by name)
    for read in (lambda: read_imu(path), lambda: list(iter_table(path, chunk_rows=30))):
        with pytest.raises(OptinavError, match="variable at byte .*: element 14") as exc:
            read()
        assert "\n" not in str(exc.value)
    # real sparse arrays (real, complex, logical, empty; in a cell too) still read
    t, acc, gyr = _columns(50)
    for m in (np.array([[0, 2.0], [3, 0]]), np.zeros((4, 3)), np.array([[1 + 2j, 0]]), np.array([[True, False]])):
        sp = scipy.sparse.csc_matrix(m)
        scipy.io.savemat(path, {"t": t, "acc": acc, "gyro": gyr, "s": sp, "c": np.array([sp], dtype=object)})
        np.testing.assert_array_equal(read_imu(path).acc, acc)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
# a byte inserted in the HDF5 file's global heap: its unit attribute failed to read while the blocks were planned
@example(mutations=[("insert", 0.8125, b"\x00")], name="e.h5")
@given(
    mutations=st.lists(
        st.tuples(
            st.sampled_from(["truncate", "replace", "insert", "delete"]),
            st.floats(0, 1),
            st.binary(min_size=1, max_size=8),
        ),
        min_size=1,
        max_size=3,
    ),
    name=st.sampled_from(["a.npz", "z.npz", "c.npy", "e.h5", "m.mat", "p.parquet", "v5.mat", "v5z.mat"]),
)
def test_fuzz_blocks_give_read_imus_log_or_a_one_line_error(tmp_path_factory, files, mutations, name):
    path = tmp_path_factory.mktemp("fuzz") / name
    path.write_bytes(_mutate(files[name].read_bytes(), mutations))
    kw = _IMU_COLUMNS.get(name, {})
    try:
        whole = read_imu(path, **kw)
    except OptinavError:
        whole = None
    try:
        logs = list(iter_imu(path, chunk_rows=30, **kw))
    except OptinavError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    if whole is not None:
        _valid(whole)
        assert np.array_equal(np.concatenate([x.t for x in logs]), whole.t)


@pytest.mark.parametrize("compress", [False, True])
def test_matlab_v5_log_read_in_blocks(tmp_path, monkeypatch, compress):
    """A MATLAB v5/v7 log (t N×1, acc and gyro N×3, stored column-major, compressed or not) read by rows equals
    read_imu; with the default threshold its small matrices are read whole (one table)."""
    import optinav.io.arrayblocks

    t, acc, gyr = _columns(N)
    path = tmp_path / "log.mat"
    scipy.io.savemat(path, {"t": t[:, None], "acc": acc, "gyro": gyr, "rate_note": "x"}, do_compression=compress)
    whole = read_imu(path)
    chunks = iter_imu(path, chunk_rows=20)
    logs = list(chunks)
    assert chunks.table is not None and len(logs) == 11
    for attr in ("t", "acc", "gyr"):
        assert np.array_equal(np.concatenate([getattr(x, attr) for x in logs]), getattr(whole, attr))
    monkeypatch.setattr(optinav.io.arrayblocks, "_MAT_STREAM_BYTES", 1 << 20)
    assert len(list(iter_table(path, chunk_rows=20))) == 1


def test_a_real_matlab_v5_trial_read_in_blocks(monkeypatch):
    """BROAD trial 29 as published (MATLAB v5, ../shared/data/attitude/broad, CC BY 4.0): its matrices read by rows
    join to scipy's whole reading, scalars and strings as metadata in every block."""
    import optinav.io.arrayblocks
    from optinav.io.arrayblocks import mat5_names

    path = (
        Path(__file__).resolve().parents[1].parent / "shared/data/attitude/broad/29_disturbed_stationary_magnet_B.mat"
    )
    if not path.is_file():
        pytest.skip("the shared BROAD trial is not here")
    assert mat5_names(path)[:4] == ["imu_gyr", "imu_acc", "imu_mag", "opt_quat"]
    monkeypatch.setattr(optinav.io.arrayblocks, "_MAT_STREAM_BYTES", 1)
    blocks = _same_as_whole(path, 5000)
    assert len(blocks) == 11 and blocks[0].meta["sampling_rate"] == load_table(path).meta["sampling_rate"]


@pytest.mark.parametrize("where,value", [(145, 0xFF), (176, 0x00), (176, 0x7F)])
def test_a_contradicting_matlab_v5_header_is_refused_before_scipy(tmp_path, where, value):
    """scipy.io.loadmat's compiled reader crashes the process (segmentation fault) on a MATLAB v5 variable whose
    flags byte (145: complex/global/logical bits all set) or real-part data type (176) was damaged: such a header
    is refused first, in one line."""
    path = tmp_path / "x.mat"
    scipy.io.savemat(path, {"t": np.arange(5.0)[:, None]})
    raw = bytearray(path.read_bytes())
    assert raw[128] == 14 and raw[176] == 9  # miMATRIX; miDOUBLE
    raw[where] = value
    path.write_bytes(bytes(raw))
    with pytest.raises(OptinavError, match="is not a readable MATLAB file") as exc:
        load_table(path)
    assert "\n" not in str(exc.value)
