"""Bags as a recording leaves them when it does not close — the recorder killed, the disk full, the power gone — and
bags under another suffix: ROS 1 ``X.bag.active`` (no index; the last chunk still open), MCAP files without summary
or footer, rosbag2 folders without metadata.yaml. Written with rosbags' writer, then cut as the writers leave them
(ros_comm's rosbag_storage: the header's index position and an open chunk's sizes stay 0 until they are written at
close; the MCAP summary, footer and closing magic come last). What is read is exactly the messages written up to the
cut; the input is never written."""

import hashlib
import shutil
import struct
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.io import bagscan, read_imu, read_table

sys.path.insert(0, str(Path(__file__).parent))
from test_rosbag import IMU, MAG, _joined_tables, imu_topic, mag_msg, session_messages, write_bag  # noqa: E402

N = 600


def _digest(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


def _ros1(tmp_path: Path, compression=None, n=N, seed=3):
    """A ROS 1 bag of ``n`` Imu messages in chunks of ~12 KB: (its bytes, its index, t, gyr)."""
    msgs, t, gyr, _ = imu_topic(np.random.default_rng(seed), n=n, rate=200.0)
    bag = write_bag(
        tmp_path / f"full_{compression}", "ros1", {"/imu": (IMU, msgs)}, compression, chunk_threshold=12_000
    )
    return bytearray(bag.read_bytes()), bagscan.ros1_index(bag), t, gyr


def _unindexed(raw: bytearray, idx: dict, state: str) -> tuple[bytearray, int]:
    """The bag as its recording leaves it, ``state``: "closed" (every chunk closed, the index not written), "open"
    (the last chunk open: its sizes 0, no index records after it), "cut" (open, and its last record cut short).
    Also the message count of the chunks that were closed."""
    f, _, _ = bagscan._record(raw, len(bagscan._ROS1_MAGIC), len(raw))
    at = f[b"index_pos"][0]
    closed = sum(idx["counts"].values())
    if state == "closed":
        out = bytearray(raw[: idx["index_pos"]])
    else:
        pos, held = idx["chunks"][-1]
        closed -= sum(held.values())
        g, ds, de = bagscan._record(raw, pos, len(raw))
        out = bytearray(raw[:de])
        out[g[b"size"][0] : g[b"size"][0] + 4] = bytes(4)
        out[ds - 4 : ds] = bytes(4)
        if state == "cut":
            out = out[:-100]
    out[at : at + 8] = bytes(8)
    return out, closed


@pytest.mark.parametrize("compression", [None, "lz4", "bz2"])
@pytest.mark.parametrize("state", ["closed", "open", "cut"])
def test_a_ros1_recording_that_did_not_close_gives_the_messages_it_holds(tmp_path, compression, state):
    """Read from a reindexed copy: every message of the closed chunks, and of an open uncompressed chunk those
    whose records are complete (a compressed stream cut anywhere is left out, and said so); a warning says what
    was read. Streamed alike. The .bag.active file and its folder are left as they were."""
    raw, idx, t, gyr = _ros1(tmp_path, compression)
    data, closed = _unindexed(raw, idx, state)
    folder = tmp_path / "rec"
    folder.mkdir()
    active = folder / "rec.bag.active"
    active.write_bytes(data)
    before = _digest(folder)
    if compression and state != "closed":
        n = closed  # a compressed open chunk: nothing of it
    else:
        n = N - (state == "cut")  # the last record cut short
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        log = read_imu(active)
        blocks, tab = _joined_tables(active, 128)  # a second read (the attitude stream's passes): the same copy
    assert len(log) == n and np.array_equal(log.t, t[:n]) and np.array_equal(log.gyr, gyr[:n])
    assert np.array_equal(tab["gx"], gyr[:n, 0])
    assert len(blocks) == -(-n // 128) and all(b.path == active for b in blocks)  # streamed from the copy
    (text,) = [str(w.message) for w in said]  # said once
    assert text.startswith("rec.bag.active has no index (a recording that did not close, or a copy cut short): read")
    if compression and state != "closed":
        assert f"unfinished {compression}-compressed last chunk) are left out" in text
    elif state != "closed":
        assert f"and the {n - closed} complete messages of its unfinished last chunk" in text
    assert ("(an unfinished record) are left out" in text) == (state == "cut" and compression is None)
    assert _digest(folder) == before


def test_a_bag_under_another_suffix_is_read_as_the_bag_it_is(tmp_path, capsys):
    """A closed bag renamed (rec.bag.active, imu.log) is read by its signature, with no warning, and its errors name
    it (they were "give it the suffix .bag")."""
    raw, _, t, gyr = _ros1(tmp_path, n=40)
    active = tmp_path / "rec.bag.active"
    active.write_bytes(raw)
    msgs, t2, gyr2, _ = imu_topic(np.random.default_rng(5), n=30)
    mcap = write_bag(tmp_path / "m", "mcap-file", {"/imu": (IMU, msgs)}).rename(tmp_path / "imu.log")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a, m = read_imu(active), read_imu(mcap)
    assert np.array_equal(a.t, t) and np.array_equal(a.gyr, gyr)
    assert np.array_equal(m.t, t2) and np.array_equal(m.gyr, gyr2)
    assert main(["allan", str(active), "--topic", "/gps", "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rec.bag.active has no topic '/gps'" in err[0] and ".active.bag" not in err[0]


@pytest.mark.parametrize("compression", [None, "storage"])
@pytest.mark.parametrize("cut", ["summary", "chunk"])
def test_an_mcap_recording_that_did_not_close_gives_its_complete_chunks(tmp_path, cut, compression):
    """An MCAP file without summary, footer and closing magic (cut where its data end, or inside its last chunk;
    chunks plain or zstd-compressed): its complete chunks, closed in a copy with the summary the writer would have
    written for them (schema, channel, a chunk index per chunk, statistics: the same chunk and message-index
    offsets as the closed file's), so that the fast decoders read it (without one: rosbags' scan of the whole
    file, 2.7 s and 355 MiB for 1 M messages, against 0.4 s and 77 MiB: benchmarks/bench_bag_recovery.py). rosbags' writer closes a chunk at 1 MiB of records:
    2952 of these messages."""
    from optinav.io import bagrepair

    n_all = 3000
    msgs, t, gyr, _ = imu_topic(np.random.default_rng(7), n=n_all)
    path = write_bag(tmp_path / "r", "mcap-file", {"/imu": (IMU, msgs)}, compression)
    raw = path.read_bytes()
    with open(path, "rb") as fh:
        fh.read(8)
        closed = bagscan._mcap_index(fh, "/imu")
    recs, pos = [], 8
    while raw[pos] != 0x0F:
        end = pos + 9 + struct.unpack_from("<Q", raw, pos + 1)[0]
        recs.append((raw[pos], pos, end))
        pos = end
    chunks = [r for r in recs if r[0] == 0x06]
    keep = pos if cut == "summary" else chunks[-1][1] + 60
    path.write_bytes(raw[:keep])
    with pytest.warns(
        UserWarning,
        match=r"r\.mcap has no summary or footer \(a recording that did not close, or a copy cut short\): read from a closed copy",
    ):
        log = read_imu(path)
    n = len(log)
    assert n == (n_all if cut == "summary" else 2952)
    assert np.array_equal(log.t, t[:n]) and np.array_equal(log.gyr, gyr[:n])
    blocks, tab = _joined_tables(path, 1000)
    assert len(blocks) == -(-n // 1000) and np.array_equal(tab["gx"], gyr[:n, 0])
    copy = tmp_path / "copy.mcap"
    bagrepair.repair(path, copy, "mcap")
    with open(copy, "rb") as fh:
        fh.read(8)
        chans, offsets, indexes = bagscan._mcap_index(fh, "/imu")
    k = len(chunks) if cut == "summary" else len(chunks) - 1
    assert (chans, offsets, indexes) == (closed[0], closed[1][:k], closed[2][:k])


def test_a_rosbag2_folder_without_metadata_reads_its_one_file(tmp_path):
    """ros2 bag record writes metadata.yaml when it closes: a folder without one is read from its one storage
    file, with a warning (once for a command that reads it twice)."""
    msgs, t, gyr, _ = imu_topic(np.random.default_rng(9), n=50)
    folder = write_bag(tmp_path / "rec", "sqlite3", {"/imu": (IMU, msgs)})
    (folder / "metadata.yaml").unlink()
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        log = read_imu(folder)
        assert np.array_equal(_joined_tables(folder, 16)[1]["gx"], gyr[:, 0])  # a second read: said once
    assert [str(w.message) for w in said] == [
        "rec has no metadata.yaml (its recording did not close): read from its one file rec.db3"
    ]
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr)


def _split_recording(tmp_path, kind: str, parts: int, n: int, last_open: bool = False):
    """A recording split into ``parts`` storage files (``ros2 bag record --max-bag-size``: rec_0 … rec_{parts-1})
    and no metadata.yaml, with a MagneticField topic at a tenth of the rate; with ``last_open`` the last MCAP file
    ends where its data end (no summary, footer or closing magic). Returns (folder, t, gyr, mag)."""
    rng = np.random.default_rng(11)
    msgs, t, gyr, _ = imu_topic(rng, n=n)
    mag = rng.normal(0, 20e-6, (n // 10, 3))  # T, stamped as every tenth Imu message
    ns = np.round(np.arange(n) / 100.0 * 1e9).astype(np.int64) + 123  # imu_topic's stamps past 1.7e9 s
    mmsgs = [
        (
            msgs[10 * i][0] + 1000,
            lambda ts, i=i: mag_msg(ts, 1_700_000_000 + ns[10 * i] // 10**9, ns[10 * i] % 10**9, mag[i]),
        )
        for i in range(n // 10)
    ]
    folder = tmp_path / "rec"
    folder.mkdir()
    for k in range(parts):
        a, b = k * n // parts, (k + 1) * n // parts
        part = write_bag(
            tmp_path / f"part{k}",
            kind,
            {
                "/imu": (IMU, msgs[a:b]),
                "/mag": (MAG, [m for m in mmsgs if msgs[a][0] <= m[0] < msgs[b - 1][0] + 10**7]),
            },
        )
        f = next(p for p in part.iterdir() if p.suffix in (".db3", ".mcap"))
        f.rename(folder / f"rec_{k}{f.suffix}")
        shutil.rmtree(part)
    if last_open:
        last = folder / f"rec_{parts - 1}.mcap"
        raw = last.read_bytes()
        pos = 8
        while raw[pos] != 0x0F:  # to the Data End record
            pos += 9 + struct.unpack_from("<Q", raw, pos + 1)[0]
        last.write_bytes(raw[:pos])
    return folder, t, gyr, mag


@pytest.mark.parametrize("kind", ["sqlite3", "mcap", "mcap-open"])
def test_a_split_recording_without_metadata_is_read_in_the_recorders_order(tmp_path, kind):
    """A split recording that did not close (rec_0 … rec_10, the last MCAP file without its summary): its files
    read in the recorder's order — by number, rec_10 after rec_9 (by name it came second) — as ``ros2 bag reindex``
    would join them, the last closed in the copy; whole and streamed alike, the input folder unchanged. Two
    files were refused."""
    folder, t, gyr, mag = _split_recording(tmp_path, kind.split("-")[0], parts=11, n=330, last_open=kind == "mcap-open")
    before = _digest(folder)
    ext = ".db3" if kind == "sqlite3" else ".mcap"
    names = ", ".join(f"rec_{k}{ext}" for k in range(11))
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        log, whole = read_imu(folder), read_table(folder)
        blocks, tab = _joined_tables(folder, 64)
    text = [str(w.message) for w in said]
    assert text[0].startswith(
        f"rec has no metadata.yaml (its recording did not close): read from its 11 files {names} in this order"
    )
    assert ("rec_10.mcap has no summary or footer" in text[0]) == (kind == "mcap-open")
    assert len(text) == 1, text
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr)
    for j, a in enumerate("xyz"):
        assert np.array_equal(whole[f"m{a}"][::10], mag[:, j]) and np.array_equal(tab[f"m{a}"][::10], mag[:, j])
    assert len(blocks) == -(-len(t) // 64) and np.array_equal(tab["gx"], gyr[:, 0])
    assert _digest(folder) == before
    from optinav.batch import find_units

    assert [u.name for u in find_units(tmp_path)] == ["rec"]  # a batch's unit, as a closed bag folder


def test_a_folder_of_two_recordings_is_refused_in_one_line(tmp_path):
    """.db3 and .mcap files in one folder without metadata.yaml are not one recording; neither is one topic of two
    types."""
    folder, *_ = _split_recording(tmp_path, "sqlite3", parts=2, n=40)
    other = write_bag(tmp_path / "other", "mcap", {"/imu": (IMU, imu_topic(np.random.default_rng(1), n=10)[0])})
    next(other.glob("*.mcap")).rename(folder / "rec_2.mcap")
    with pytest.raises(OptinavError, match=r"holds both \.db3 and \.mcap files .* not one recording"):
        read_imu(folder)
    (folder / "rec_2.mcap").unlink()
    wrong = write_bag(tmp_path / "wrong", "sqlite3", {"/imu": (MAG, [])})
    next(wrong.glob("*.db3")).rename(folder / "rec_2.db3")
    with pytest.raises(
        OptinavError,
        match=r"topic /imu is sensor_msgs/msg/Imu in one file of rec and sensor_msgs/msg/MagneticField in rec_2\.db3",
    ):
        read_imu(folder)


@settings(max_examples=40)
@given(kind=st.sampled_from(["ros1", "ros1-lz4", "mcap"]), share=st.floats(0.0, 1.0))
def test_a_bag_cut_anywhere_gives_a_prefix_of_its_messages_or_one_line(tmp_path_factory, kind, share):
    """A recording cut at any byte (a ROS 1 bag with no index, an MCAP file): the messages read are exactly the
    first ones written, at least those of the chunks complete before the cut (and of an uncompressed chunk cut
    short, its complete records); a refusal, where no chunk is complete, is one line (no traceback)."""
    tmp = tmp_path_factory.mktemp("cut")
    msgs, t, gyr, _ = imu_topic(np.random.default_rng(11), n=200)
    if kind == "mcap":
        path = write_bag(tmp / "b", "mcap-file", {"/imu": (IMU, msgs)})
    else:
        path = write_bag(tmp / "b", "ros1", {"/imu": (IMU, msgs)}, kind[5:] or None, chunk_threshold=4000)
    raw = bytearray(path.read_bytes())
    cut = max(1, int(share * len(raw)))
    if kind == "mcap":  # one chunk: all of it once the data section is whole
        due = len(msgs) if cut >= raw.rfind(b"\x0f\x04\x00\x00\x00\x00\x00\x00\x00") else 0
    else:
        idx = bagscan.ros1_index(path)
        f, _, _ = bagscan._record(raw, len(bagscan._ROS1_MAGIC), len(raw))
        raw[f[b"index_pos"][0] : f[b"index_pos"][0] + 8] = bytes(8)
        ends = [p for p, _ in idx["chunks"][1:]] + [idx["index_pos"]]  # each chunk with its index records
        due = sum(sum(held.values()) for (_, held), end in zip(idx["chunks"], ends) if end <= cut)
    path.write_bytes(raw[:cut])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            log = read_imu(path)
    except OptinavError as exc:
        assert "\n" not in str(exc) and due == 0
        return
    n = len(log)
    assert n >= due and np.array_equal(log.t, t[:n]) and np.array_equal(log.gyr, gyr[:n])


def test_calibrate_from_a_recording_that_did_not_close(tmp_path, capsys):
    """The CLI end to end: a simulated multi-position session recorded to a ROS 1 bag that did not close calibrates
    like its samples as CSV; the console says what was read."""
    csv, _, msgs = session_messages(tmp_path)
    bag = write_bag(tmp_path / "bag", "ros1", {"/imu": (IMU, msgs)})
    data, _ = _unindexed(bytearray(bag.read_bytes()), bagscan.ros1_index(bag), "closed")
    active = tmp_path / "session.bag.active"
    active.write_bytes(data)
    out_csv, out_bag = tmp_path / "c.json", tmp_path / "b.json"
    assert main(["--quiet", "calibrate", "accel", str(csv), "--gravity", "9.80", "--out", str(out_csv)]) == 0
    capsys.readouterr()
    assert main(["calibrate", "accel", str(active), "--gravity", "9.80", "--out", str(out_bag)]) == 0
    assert "session.bag.active has no index (a recording that did not close" in capsys.readouterr().err
    from optinav.multipos.result import CalibrationResult

    rc, rb = CalibrationResult.from_json(out_csv), CalibrationResult.from_json(out_bag)
    for sensor in ("accelerometer", "gyroscope"):
        np.testing.assert_allclose(getattr(rb, sensor)["K"], getattr(rc, sensor)["K"], rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(getattr(rb, sensor)["b"], getattr(rc, sensor)["b"], rtol=1e-6, atol=1e-6)


def test_copies_are_made_once_per_file_and_removed(tmp_path):
    """A command that reads its input twice repairs it once (same path, size and time: the same copy); the copies
    of the files read before the last two are removed, so a batch of such bags does not fill the temporary disk."""
    from optinav.io import rosbag

    raw, idx, t, _ = _ros1(tmp_path, n=60)
    data, _ = _unindexed(raw, idx, "closed")
    paths = []
    for k in range(3):
        paths.append(tmp_path / f"r{k}.bag.active")
        paths[-1].write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        read_imu(paths[0])
        first = next(twin for key, (_, twin) in rosbag._TWINS.items() if key[0][0] == str(paths[0].resolve()))
        assert np.array_equal(read_imu(paths[0]).t, t) and first.exists()
        for p in paths[1:]:
            read_imu(p)
    assert not first.parent.exists() and all(twin.exists() for _, twin in rosbag._TWINS.values())
    assert {key[0][0] for key in rosbag._TWINS} == {str(p.resolve()) for p in paths[1:]}


@pytest.mark.parametrize("kind", ["mcap", "sqlite3"])
def test_a_bag_compressed_file_by_file_streams_from_its_inflated_copy(tmp_path, kind):
    """``ros2 bag record --compression-mode file``: inflated once into a temporary folder (the same copy for a
    second read) and streamed from it in blocks — it was read whole, and inflated again by each read."""
    from optinav.io import rosbag

    msgs, t, gyr, _ = imu_topic(np.random.default_rng(3), n=500)
    bag = write_bag(tmp_path / kind, kind, {"/imu": (IMU, msgs)}, compression="file")
    blocks, tab = _joined_tables(bag, 100)
    assert len(blocks) == 5 and all(b.path == bag for b in blocks)
    assert np.array_equal(tab["t"], t) and np.array_equal(tab["gx"], gyr[:, 0])
    copies = [twin for _, twin in rosbag._TWINS.values() if twin.name == bag.name]
    assert len(copies) == 1 and np.array_equal(read_imu(bag).gyr, gyr)
    assert [twin for _, twin in rosbag._TWINS.values() if twin.name == bag.name] == copies
