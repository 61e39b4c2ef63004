"""ROS bags as input: ROS 1 .bag and ROS 2 (sqlite3 and mcap, as a folder or a bare file) written with rosbags'
own writer and serializer are read back with the values written; topic choice, time base and every refusal."""

import gc
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from rosbags.rosbag1 import Writer as Writer1
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from optinav.cli.main import main
from optinav.errors import OptinavError
from optinav.io import iter_imu, read_imu, read_table
from optinav.io.rosbag import load_bag

TS1 = get_typestore(Stores.ROS1_NOETIC)
TS2 = get_typestore(Stores.ROS2_HUMBLE)
IMU, MAG, STR = "sensor_msgs/msg/Imu", "sensor_msgs/msg/MagneticField", "std_msgs/msg/String"
KINDS = ("ros1", "sqlite3", "mcap", "sqlite3-file", "mcap-file")


def _header(ts, sec, nsec, frame, seq):
    H, T = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    stamp = T(sec=int(sec), nanosec=int(nsec))
    return (
        H(seq=seq, stamp=stamp, frame_id=frame) if "seq" in H.__dataclass_fields__ else H(stamp=stamp, frame_id=frame)
    )


def imu_msg(ts, sec, nsec, gyr, acc, frame="imu_link", seq=0):
    V, Q = ts.types["geometry_msgs/msg/Vector3"], ts.types["geometry_msgs/msg/Quaternion"]
    z9 = np.zeros(9)
    return ts.types[IMU](
        header=_header(ts, sec, nsec, frame, seq),
        orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=z9,
        angular_velocity=V(*map(float, gyr)),
        angular_velocity_covariance=z9,
        linear_acceleration=V(*map(float, acc)),
        linear_acceleration_covariance=z9,
    )


def mag_msg(ts, sec, nsec, b, frame="mag", seq=0):
    V = ts.types["geometry_msgs/msg/Vector3"]
    return ts.types[MAG](
        header=_header(ts, sec, nsec, frame, seq),
        magnetic_field=V(*map(float, b)),
        magnetic_field_covariance=np.zeros(9),
    )


def write_bag(
    path: Path, kind: str, topics: dict, compression: str | None = None, big_endian=(), chunk_threshold=None
) -> Path:
    """``topics``: ``{name: (msgtype, [(log_time_ns, message_factory(ts)), ...])}`` → the bag to pass to optinav.
    ``compression``: ROS 1 chunks ``"bz2"``/``"lz4"``; ROS 2 ``"storage"`` (zstd chunks) or ``"message"`` (zstd
    per message); ``big_endian``: indices of the messages (of every topic) serialized as big-endian CDR."""
    if kind == "ros1":
        path = path.with_suffix(".bag")
        w = Writer1(path)
        if chunk_threshold is not None:  # bytes of a ROS 1 chunk (rosbags: 1 MiB)
            w.chunk_threshold = chunk_threshold
        if compression:
            w.set_compression(Writer1.CompressionFormat[compression.upper()])
        with w:
            for name, (msgtype, msgs) in topics.items():
                con = w.add_connection(name, msgtype, typestore=TS1)
                for t_ns, make in msgs:
                    w.write(con, t_ns, TS1.serialize_ros1(make(TS1), msgtype))
        return path
    plugin = StoragePlugin.MCAP if kind.startswith("mcap") else StoragePlugin.SQLITE3
    w = Writer2(path, version=9, storage_plugin=plugin)
    if compression:
        w.set_compression(CompressionMode[compression.upper()], CompressionFormat.ZSTD)
    with w:
        for name, (msgtype, msgs) in topics.items():
            con = w.add_connection(name, msgtype, typestore=TS2)
            for i, (t_ns, make) in enumerate(msgs):
                w.write(con, t_ns, TS2.serialize_cdr(make(TS2), msgtype, little_endian=i not in big_endian))
    if kind.endswith("-file"):
        return next(p for p in path.iterdir() if p.suffix in (".db3", ".mcap"))
    return path


def imu_topic(rng, n=40, rate=100.0, t0=1_700_000_000, frames=("imu_link",), stamps=None):
    """Messages and the values they hold: (messages, t, gyr, acc). ``frames``: the header frame_ids, each over
    its share of the messages in turn (one IMU whose driver was restarted under another frame_id); ``imu_topic``
    pairs with :func:`interleaved` for several IMUs on one topic."""
    gyr = rng.normal(0, 0.5, (n, 3))
    acc = rng.normal(0, 3, (n, 3)) + [0, 0, 9.81]
    ns = np.round(np.arange(n) / rate * 1e9).astype(np.int64) + 123 if stamps is None else stamps
    msgs = [
        (
            int(t0 * 10**9 + ns[i] + 5_000_000),
            lambda ts, i=i: imu_msg(
                ts, t0 + ns[i] // 10**9, ns[i] % 10**9, gyr[i], acc[i], frame=frames[i * len(frames) // n], seq=i
            ),
        )
        for i in range(n)
    ]
    t = (t0 + ns // 10**9) + (ns % 10**9) * 1e-9
    return msgs, t, gyr, acc


@pytest.mark.parametrize("kind", KINDS)
def test_values_read_equal_values_written(tmp_path, kind):
    rng = np.random.default_rng(1)
    msgs, t, gyr, acc = imu_topic(rng)
    tm = np.arange(0, 0.2, 0.04) + 1_700_000_000
    bm = rng.normal(0, 3e-5, (tm.size, 3))
    mags = [
        (int(round(x * 1e9)), lambda ts, k=k: mag_msg(ts, int(tm[k]), round((tm[k] % 1) * 1e9), bm[k]))
        for k, x in enumerate(tm)
    ]
    chatter = [(1_700_000_000 * 10**9 + k, lambda ts, k=k: ts.types[STR](data="x" * k)) for k in range(3)]
    bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs), "/mag": (MAG, mags), "/chatter": (STR, chatter)})
    log = read_imu(bag)
    assert np.array_equal(log.t, t)
    assert np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    assert log.acc_input_unit == "m/s^2" and log.gyro_input_unit == "rad/s"
    tab = read_table(bag)
    mag_t = (tm.astype(np.int64)) + np.round((tm % 1) * 1e9) * 1e-9
    for j, a in enumerate("xyz"):
        expect = np.interp(t, mag_t, bm[:, j])
        expect[t > mag_t[-1] + 0.08] = np.nan
        np.testing.assert_allclose(tab[f"m{a}"], expect, rtol=0, atol=1e-18)
    assert np.isnan(tab["mx"][-1]) and np.all(np.isfinite(tab["mx"][:24]))


@pytest.mark.parametrize("kind", ("ros1", "sqlite3"))
def test_frame_ids_of_different_lengths(tmp_path, kind):
    # messages of several sizes: one fixed layout per size, the rest through rosbags' deserializer
    rng = np.random.default_rng(2)
    msgs, t, gyr, acc = imu_topic(rng, n=30, frames=("a", "imu", "imu_link_long_name", "xyz"))
    bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs)})
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def rosbags_reference(bag, topic):
    """Every message of ``topic`` through rosbags' reader and deserializer, in its order: rows of header stamp (s)
    and values (Imu: gyr, acc; MagneticField: mag)."""
    rows = []
    with AnyReader([bag]) as r:
        for con, _, raw in r.messages(connections=[c for c in r.connections if c.topic == topic]):
            m = r.deserialize(raw, con.msgtype)
            vecs = (m.angular_velocity, m.linear_acceleration) if con.msgtype == IMU else (m.magnetic_field,)
            rows.append(
                [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9] + [x for v in vecs for x in (v.x, v.y, v.z)]
            )
    return np.array(rows)


SCANNED = [
    ("ros1", None),
    ("ros1", "bz2"),
    ("ros1", "lz4"),
    ("mcap", None),
    ("mcap", "storage"),
    ("mcap-file", None),
    ("sqlite3", None),
    ("sqlite3-file", None),
]


@pytest.mark.parametrize(("kind", "compression"), SCANNED + [("mcap", "message"), ("sqlite3", "message")])
def test_storage_scan_equals_rosbags(tmp_path, monkeypatch, kind, compression):
    """The values equal rosbags' deserializer message for message: Imu with frame ids of several lengths (some
    messages through the deserializer), a MagneticField topic interleaved, chunks compressed or not. Bags the
    scanners read never touch rosbags' iteration (nor, ROS 1, its reader)."""
    import optinav.io.rosbag as rb

    rng = np.random.default_rng(11)
    msgs, *_ = imu_topic(rng, n=300, rate=1000.0, frames=("imu",) * 40 + ("imu_link_long",) + ("imu",) * 20 + ("",))
    tm = 1_700_000_000 + np.arange(0, 0.3, 0.01)
    bm = rng.normal(0, 3e-5, (tm.size, 3))
    mags = [
        (int(round(x * 1e9)) + 7, lambda ts, k=k: mag_msg(ts, int(tm[k]), round((tm[k] % 1) * 1e9), bm[k]))
        for k, x in enumerate(tm)
    ]
    bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs), "/mag": (MAG, mags)}, compression=compression)
    ref, ref_mag = rosbags_reference(bag, "/imu"), rosbags_reference(bag, "/mag")
    if (kind, compression) in SCANNED or (compression == "message" and _libzstd()):
        monkeypatch.setattr(rb, "_rosbags_blocks", None)
    if (kind, compression) in SCANNED:
        if kind.startswith(("ros1", "sqlite3")):  # read without opening rosbags' reader
            import rosbags.highlevel

            monkeypatch.setattr(rosbags.highlevel, "AnyReader", None)
    tab = read_table(bag)
    assert np.array_equal(tab["t"], ref[:, 0])
    got = np.column_stack([tab[c] for c in ("gx", "gy", "gz", "ax", "ay", "az")])
    assert np.array_equal(got, ref[:, 1:])
    for j, a in enumerate("xyz"):
        expect = np.interp(ref[:, 0], ref_mag[:, 0], ref_mag[:, 1 + j])
        assert np.array_equal(tab[f"m{a}"], expect)


def test_ros1_chunks_without_the_topic_are_skipped(tmp_path, monkeypatch):
    """A ROS 1 bag whose first chunks hold only another topic (1.5 MB of strings, rosbags' chunks are 1 MB): the
    Imu values come from the chunks the index lists for it, read without opening rosbags' reader."""
    import rosbags.highlevel

    rng = np.random.default_rng(15)
    msgs, t, gyr, acc = imu_topic(rng, n=80)
    chatter = [(1_600_000_000 * 10**9 + k, lambda ts, k=k: ts.types[STR](data=str(k % 10) * 5000)) for k in range(300)]
    bag = write_bag(tmp_path / "c", "ros1", {"/chatter": (STR, chatter), "/imu": (IMU, msgs)})
    monkeypatch.setattr(rosbags.highlevel, "AnyReader", None)
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


class _SpyPool:
    """A stand-in for bagscan's helper thread that counts the jobs handed to it (run in a real thread)."""

    def __init__(self, workers=1):
        from concurrent.futures import ThreadPoolExecutor

        self.pool, self.jobs = ThreadPoolExecutor(max_workers=workers), 0

    def submit(self, fn, *args):
        self.jobs += 1
        return self.pool.submit(fn, *args)


def _spy_decode(monkeypatch, name="ros1_decode"):
    """Record what every call of the whole-topic decoder ``bagscan.<name>`` returns."""
    from optinav.io import bagscan

    calls, real = [], getattr(bagscan, name)

    def spy(*args, **kw):
        calls.append(real(*args, **kw))
        return calls[-1]

    monkeypatch.setattr(bagscan, name, spy)
    return calls


def _spy_threads(monkeypatch, name, slow="main"):
    """Record (thread is this one, the kernel's chunks argument) for every call of the compiled kernel
    ``_bagkernels.<name>``; the calls of the ``slow`` thread ("main", "helper") wait 20 ms first, so that the other
    takes batches too (or most of them; with 2 ms a busy machine left the other descheduled: 1 batch of 9)."""
    import threading
    import time

    from optinav.io import _bagkernels as kern

    real, seen, me = getattr(kern, name), [], threading.get_ident()

    def spy(*args):
        mine = threading.get_ident() == me
        seen.append((mine, tuple(np.asarray(args[1]).tolist())))
        if mine == (slow == "main"):
            time.sleep(0.02)
        return real(*args)

    monkeypatch.setattr(kern, name, spy)
    return seen


def test_ros1_chunks_decoded_in_rounds_by_two_threads(tmp_path, monkeypatch):
    """A plain ROS 1 bag of many chunks (Imu and MagneticField in each) is decoded chunk by chunk in batches taken
    by this thread and a helper thread in turn: the values written, exactly, and the same with one thread."""
    from optinav.io import bagscan

    rng = np.random.default_rng(21)
    msgs, t, gyr, acc = imu_topic(rng, n=1500, rate=1000.0)
    mags = [(int((1_700_000_000 + k * 0.01) * 1e9), lambda ts, k=k: mag_msg(ts, 1_700_000_000, 10**7 * k, rng.normal(0, 1e-5, 3))) for k in range(150)]  # fmt: skip
    # the topics written in turns, so that chunks hold both
    both = {"/imu": (IMU, []), "/mag": (MAG, [])}
    bag = tmp_path / "b.bag"
    w = Writer1(bag)
    w.chunk_threshold = 16384
    with w:
        cons = {name: w.add_connection(name, typ, typestore=TS1) for name, (typ, _) in both.items()}
        for i, (t_ns, make) in enumerate(msgs):
            w.write(cons["/imu"], t_ns, TS1.serialize_ros1(make(TS1), IMU))
            if i % 10 == 0:
                t_m, make_m = mags[i // 10]
                w.write(cons["/mag"], t_m, TS1.serialize_ros1(make_m(TS1), MAG))
    idx = bagscan.ros1_index(bag)
    assert len(idx["chunks"]) > 20 and all(len(held) == 2 for _, held in idx["chunks"])
    calls = _spy_decode(monkeypatch)
    monkeypatch.setattr(bagscan, "_ROUND", 50_000)  # three or four chunks a batch
    spy = _SpyPool()
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    seen = _spy_threads(monkeypatch, "ros1_decode")
    log = read_imu(bag)
    assert calls == [True, True] and spy.jobs == 2  # both topics
    # the helper took batches (this thread's calls wait 2 ms: on a loaded machine the helper may take them all)
    assert sum(not m for m, _ in seen) >= 1
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    mag = read_table(bag)["mz"]
    monkeypatch.setattr(bagscan, "_helper", lambda: None)
    del calls[:]
    log1 = read_imu(bag)
    assert calls == [True, True]
    assert np.array_equal(log1.t, t) and np.array_equal(log1.gyr, gyr) and np.array_equal(log1.acc, acc)
    assert np.array_equal(read_table(bag)["mz"], mag, equal_nan=True)


@pytest.mark.parametrize("slow", ["main", "helper"])
def test_batches_go_to_the_thread_that_is_free(tmp_path, monkeypatch, slow):
    """A bag's batches of chunks are taken by whichever thread is free (ROS 1 here; MCAP shares the rounds): with
    one thread slowed (another process on its CPU), the other decodes most of them, every chunk exactly once,
    and the values are those of one thread and those written (odd message counts, Imu and MagneticField in turns
    in every chunk)."""
    from optinav.io import bagscan

    rng = np.random.default_rng(5)
    msgs, t, gyr, acc = imu_topic(rng, n=3001, rate=1000.0)
    mags = [(int((1_700_000_000 + k * 0.01) * 1e9) + 7, lambda ts, k=k: mag_msg(ts, 1_700_000_000, 10**7 * k + 7, rng.normal(0, 1e-5, 3))) for k in range(301)]  # fmt: skip
    merged = sorted([(ts, "/imu", m) for ts, m in msgs] + [(ts, "/mag", m) for ts, m in mags], key=lambda x: x[0])
    bag = tmp_path / "b.bag"
    w = Writer1(bag)
    w.chunk_threshold = 16384
    with w:
        cons = {name: w.add_connection(name, typ, typestore=TS1) for name, typ in (("/imu", IMU), ("/mag", MAG))}
        for ts, name, make in merged:
            w.write(cons[name], ts, TS1.serialize_ros1(make(TS1), IMU if name == "/imu" else MAG))
    monkeypatch.setattr(bagscan, "_helper", lambda: None)
    one = read_table(bag)
    monkeypatch.setattr(bagscan, "_ROUND", 20_000)  # a chunk or two a batch
    spy = _SpyPool()
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    calls = _spy_decode(monkeypatch, "ros1_decode")
    seen = _spy_threads(monkeypatch, "ros1_decode", slow=slow)
    two = read_table(bag)
    assert calls == [True, True] and spy.jobs == 2
    for k in one:
        assert np.array_equal(two[k], one[k], equal_nan=True), k
    n = len(seen) // 2  # each topic's calls (the Imu topic's, then the MagneticField's: the same chunks)
    for topic in (seen[:n], seen[n:]):
        chunks = [c for _, cs in topic for c in cs]
        assert len(chunks) == len(set(chunks)) >= 16  # every chunk once
        fast = sum(m != (slow == "main") for m, _ in topic)
        assert fast > 0.6 * len(topic), (slow, [m for m, _ in topic])
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


@pytest.mark.parametrize("kind", ("ros1", "sqlite3", "mcap"))
def test_fine_stamps_are_judged_once_per_read(tmp_path, monkeypatch, kind):
    """A topic's header stamps, set and strictly increasing, are judged so once in a read (three passes before:
    copies to leave out, an order to mend, the time base; 3 ms each for 3.6 M messages), and read as they are;
    stamps that step back in the log are still put in stamp order with the warning."""
    from optinav.io import rosbag

    calls = []
    own_ok = rosbag._stamps_ok
    monkeypatch.setattr(rosbag, "_stamps_ok", lambda s: calls.append(s.size) or own_ok(s))
    rng = np.random.default_rng(67)
    msgs, t, gyr, acc = imu_topic(rng, n=300)
    log = read_imu(write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs)}))
    assert calls == [300] and np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr)
    late = [(t_ns + (30_000_000 if i == 100 else 0), make) for i, (t_ns, make) in enumerate(msgs)]
    with pytest.warns(UserWarning, match="3 of the 300 messages .* were logged out of their header stamps"):
        log = read_imu(write_bag(tmp_path / "late", kind, {"/imu": (IMU, late)}))
    assert np.array_equal(log.t, t) and np.array_equal(log.acc, acc)


def test_a_bag_s_own_definitions_like_the_store_s_are_deserialized_by_the_store(tmp_path, monkeypatch):
    """rosbags' reader builds a type store from a ROS 2 bag's definitions at each opening, whose code for
    sensor_msgs/Imu was generated again at each read (10-16 ms): where the bag defines the type and every type in
    it field for field as the process's store does, that store deserializes; a definition of its own (another
    field type in one nested type), or a ROS 1 bag, keeps the reader's."""
    from types import SimpleNamespace

    from optinav.io import rosbag

    calls = []
    own = AnyReader.deserialize
    monkeypatch.setattr(AnyReader, "deserialize", lambda self, *a: calls.append(a[1]) or own(self, *a))
    rng = np.random.default_rng(71)
    msgs, t, gyr, acc = imu_topic(rng, n=300)
    log = read_imu(write_bag(tmp_path / "b", "mcap", {"/imu": (IMU, msgs)}))
    assert not calls and np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    store = rosbag._store("LATEST")
    defs = dict(store.fielddefs)
    consts, fields = defs["geometry_msgs/msg/Vector3"]
    defs["geometry_msgs/msg/Vector3"] = (consts, [(n, (d[0], ("float32", 0))) for n, d in fields])
    for reader in (
        SimpleNamespace(is2=True, typestore=SimpleNamespace(fielddefs=defs)),
        SimpleNamespace(is2=False, typestore=SimpleNamespace(fielddefs=dict(store.fielddefs))),
    ):
        assert rosbag._deserializer(reader, IMU) is reader
    same = SimpleNamespace(is2=True, typestore=SimpleNamespace(fielddefs=dict(store.fielddefs)))
    assert rosbag._deserializer(same, IMU).store is store


@given(st.lists(st.sampled_from([0.0, -1.0, 0.5, 1.0, 1.0, 2.0, 3.5, np.nan, np.inf, -np.inf]), max_size=8))
def test_stamps_ok_means_set_and_strictly_increasing(values):
    """The quick test of header stamps (s) agrees with its definition: every stamp positive, every step
    positive (NaN neither)."""
    from optinav.io.rosbag import _stamps_ok

    s = np.array(values, dtype=float)
    with np.errstate(invalid="ignore"):
        want = bool(s.size and np.all(s > 0) and np.all(np.diff(s) > 0))
    assert _stamps_ok(s) == want


def test_ros1_decode_declines_what_the_blocks_read(tmp_path, monkeypatch):
    """The chunk decoder gives up — and the block reader reads the bag, with the values written — for compressed
    chunks, for a message of another layout in a later chunk, and (called directly) for chunk counts other than the
    chunk infos' or that do not add up to the topic's count."""
    import optinav.io.rosbag as rb
    from optinav.io import bagscan

    rng = np.random.default_rng(22)
    calls = _spy_decode(monkeypatch)
    msgs, t, gyr, acc = imu_topic(rng, n=400, rate=1000.0)
    bag = write_bag(tmp_path / "lz4", "ros1", {"/imu": (IMU, msgs)}, compression="lz4", chunk_threshold=8192)
    log = read_imu(bag)
    assert calls == [False]
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    frames = ("imu",) * 300 + ("imu_link_long",) + ("imu",) * 99  # a longer message in the fourth chunk or so
    msgs, t, gyr, acc = imu_topic(rng, n=400, rate=1000.0, frames=frames)
    bag = write_bag(tmp_path / "odd", "ros1", {"/imu": (IMU, msgs)}, chunk_threshold=8192)
    log = read_imu(bag)
    assert calls[1:] == [False]
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    # the chunk infos' counts against what the chunks hold
    msgs, t, gyr, acc = imu_topic(rng, n=400, rate=1000.0)
    bag = write_bag(tmp_path / "plain", "ros1", {"/imu": (IMU, msgs)}, chunk_threshold=8192)
    idx = bagscan.ros1_index(bag)
    conn = next(iter(idx["chunks"][0][1]))
    dec = rb._Decoder(rb._Ros1Types(), True, IMU, 400)
    out = (dec.stamp, dec.logt, dec.vals[0], dec.vals[1])
    cons = np.array([conn], dtype=np.int64)
    assert bagscan.ros1_decode(bag, idx, cons, dec.kernel_layout, out)
    assert np.array_equal(dec.vals[0], gyr) and np.array_equal(dec.logt, [m[0] for m in msgs])
    for shift in ((1, -1), (1, 0), (0, -1)):  # counts moved between two chunks, one too many, one too few
        bad = {**idx, "chunks": [(pos, dict(held)) for pos, held in idx["chunks"]]}
        bad["chunks"][1][1][conn] += shift[0]
        bad["chunks"][-1][1][conn] += shift[1]
        assert not bagscan.ros1_decode(bag, bad, cons, dec.kernel_layout, out)
    assert not bagscan.ros1_decode(bag, idx, cons, lambda raw: None, out)  # a layout not read: declined


@pytest.mark.parametrize(("kind", "compression"), [("ros1", "bz2"), ("ros1", "lz4"), ("mcap", "storage")])
def test_compressed_chunks_inflated_ahead_by_helper_threads(tmp_path, monkeypatch, kind, compression):
    """Chunks compressed with a slow codec (bz2, zstd) are inflated by the helper threads ahead of the walk, lz4 in
    turn: the values written either way, in order, and the same with no helper thread."""
    from optinav.io import bagscan

    rng = np.random.default_rng(23)
    # rosbags closes an MCAP chunk at 1 MiB (not settable): 7000 messages make three
    msgs, t, gyr, acc = imu_topic(rng, n=1200 if kind == "ros1" else 7000, rate=1000.0)
    thr = {"chunk_threshold": 8192} if kind == "ros1" else {}
    bag = write_bag(tmp_path / "z", kind, {"/imu": (IMU, msgs)}, compression=compression, **thr)
    spy = _SpyPool(workers=2)
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    monkeypatch.setattr(bagscan, "_workers", lambda: 2)
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    if kind == "ros1":
        chunks = len(bagscan.ros1_index(bag)["chunks"])
    else:
        with open(next(bag.glob("*.mcap")), "rb") as fh:
            chunks = len(bagscan._mcap_index(fh, "/imu")[1])
    assert chunks >= 3 and spy.jobs == (0 if compression == "lz4" else chunks)  # every chunk of a slow codec
    monkeypatch.setattr(bagscan, "_helper", lambda: None)
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


@pytest.mark.parametrize("damage", ["conn to the other topic", "conn unknown", "count"])
def test_ros1_chunk_info_against_the_chunks_index_records(tmp_path, damage):
    """A damaged chunk info (its Imu connection id turned into the other topic's or an unknown one, or its count
    changed) would make the scanners skip or miscount a chunk while the counts still add up; checked against the
    index data records after each chunk, such a bag is read by rosbags: the values written, all of them."""
    import struct

    from optinav.io import bagscan

    rng = np.random.default_rng(24)
    msgs, t, gyr, acc = imu_topic(rng, n=300, rate=1000.0)
    mags = [(1_700_000_000 * 10**9 + 10**7 * k, lambda ts, k=k: mag_msg(ts, 1_700_000_000, 10**7 * k, [1e-5, 0, 0])) for k in range(8)]  # fmt: skip
    bag = write_bag(tmp_path / "b", "ros1", {"/imu": (IMU, msgs), "/mag": (MAG, mags)}, chunk_threshold=2048)
    idx = bagscan.ros1_index(bag)
    imu = next(c for c, v in idx["conns"].items() if v[0] == "/imu")
    mag = next(c for c, v in idx["conns"].items() if v[0] == "/mag")
    raw = bytearray(bag.read_bytes())
    pos, at = idx["index_pos"], None
    while pos < len(raw):  # the (conn, count) pair of Imu in the last chunk info that lists it
        f, ds, de = bagscan._record(bytes(raw), pos, len(raw))
        if bagscan._op(bytes(raw), f) == 0x06:
            for k in range(ds, de, 8):
                if struct.unpack_from("<I", raw, k)[0] == imu:
                    at, count = k, struct.unpack_from("<I", raw, k + 4)[0]
        pos = de
    if damage == "count":
        struct.pack_into("<I", raw, at + 4, count + 1)
    else:
        struct.pack_into("<I", raw, at, mag if damage == "conn to the other topic" else 99)
    bad = tmp_path / "bad.bag"
    bad.write_bytes(bytes(raw))
    with pytest.raises(bagscan.NotFast, match="index records"):
        bagscan._ros1_selected(bagscan.ros1_index(bad), np.frombuffer(bytes(raw), np.uint8), np.array([imu]))
    ref = rosbags_reference(bad, "/imu")
    assert np.array_equal(ref[:, 0], t)  # rosbags reads the chunks' own index records
    log = read_imu(bad)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def test_mcap_chunks_decoded_in_rounds_by_two_threads(tmp_path, monkeypatch):
    """An MCAP file of several uncompressed chunks is decoded chunk by chunk in batches taken by this thread and a
    helper thread in turn, each chunk's rows from its Message Index records: the values written. Declined — the blocks read it,
    the same values — for zstd chunks, a message of another layout in a later chunk, and a Message Index whose
    count was changed."""
    import struct

    from optinav.io import bagscan

    rng = np.random.default_rng(26)
    calls = _spy_decode(monkeypatch, "mcap_decode")
    monkeypatch.setattr(bagscan, "_ROUND", 1 << 20)  # a chunk a batch
    spy = _SpyPool()
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    msgs, t, gyr, acc = imu_topic(rng, n=13000, rate=1000.0)  # four 1 MiB chunks (rosbags' size)
    bag = write_bag(tmp_path / "m", "mcap", {"/imu": (IMU, msgs)})
    seen = _spy_threads(monkeypatch, "mcap_decode")
    log = read_imu(bag)
    assert calls == [True] and spy.jobs == 1
    # the helper took batches (this thread's calls wait 2 ms: on a loaded machine the helper may take them all)
    assert sum(not m for m, _ in seen) >= 1
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    zst = write_bag(tmp_path / "z", "mcap", {"/imu": (IMU, msgs[:4000])}, compression="storage")
    log = read_imu(zst)
    assert calls[1:] == [False] and np.array_equal(log.gyr, gyr[:4000])
    frames = ("imu",) * 9000 + ("imu_link_long",) + ("imu",) * 3999
    msgs2, t2, gyr2, acc2 = imu_topic(rng, n=13000, rate=1000.0, frames=frames)
    odd = write_bag(tmp_path / "o", "mcap", {"/imu": (IMU, msgs2)})
    log = read_imu(odd)
    assert calls[2:] == [False]
    assert np.array_equal(log.t, t2) and np.array_equal(log.gyr, gyr2) and np.array_equal(log.acc, acc2)
    # one Message Index record's count changed (its records' byte length, 16 bytes a message)
    mcap = next(bag.glob("*.mcap"))
    raw = bytearray(mcap.read_bytes())
    with open(mcap, "rb") as fh:
        _, _, indexes = bagscan._mcap_index(fh, "/imu")
    m = indexes[1][0]
    struct.pack_into("<I", raw, m + 11, struct.unpack_from("<I", raw, m + 11)[0] - 16)
    mcap.write_bytes(bytes(raw))
    ours, ref = _read_both(bag)
    assert calls[3:4] == [False]
    assert isinstance(ours, dict) and np.array_equal(ours["t"], ref["t"])


def _with_chunk_crcs(mcap: Path) -> list[tuple[int, int]]:
    """Write each uncompressed Chunk record's CRC-32 into its header (as the mcap library does by default;
    rosbags writes 0: none); the (start, end) of each chunk's records."""
    import struct
    import zlib

    raw = bytearray(mcap.read_bytes())
    pos, spans = 8, []
    while pos + 9 <= len(raw) and raw[pos] not in (0x0F, 0x02):  # up to Data End / Footer
        n = struct.unpack_from("<Q", raw, pos + 1)[0]
        if raw[pos] == 0x06:
            s = pos + 9
            assert struct.unpack_from("<I", raw, s + 28)[0] == 0  # no compression
            rlen = struct.unpack_from("<Q", raw, s + 32)[0]
            struct.pack_into("<I", raw, s + 24, zlib.crc32(raw[s + 40 : s + 40 + rlen]))
            spans.append((s + 40, s + 40 + rlen))
        pos += 9 + n
    mcap.write_bytes(bytes(raw))
    return spans


def test_mcap_chunks_with_a_crc_are_checked_and_decoded_whole(tmp_path, monkeypatch):
    """MCAP chunks that carry a CRC-32 (the mcap library's and CLI's default) are checked (bagscan.crc32) in the
    thread that walks them and decoded by the whole-topic decoder (were read through the blocks); a byte changed in a
    chunk's records fails its CRC: declined, then refused as rosbags refuses it."""
    from optinav.io import bagscan

    rng = np.random.default_rng(27)
    calls = _spy_decode(monkeypatch, "mcap_decode")
    monkeypatch.setattr(bagscan, "_ROUND", 2 << 20)
    spy = _SpyPool()
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    msgs, t, gyr, acc = imu_topic(rng, n=13000, rate=1000.0)
    bag = write_bag(tmp_path / "c", "mcap", {"/imu": (IMU, msgs)})
    mcap = next(bag.glob("*.mcap"))
    spans = _with_chunk_crcs(mcap)
    assert len(spans) >= 3
    log = read_imu(bag)
    assert calls == [True] and spy.jobs >= 1
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    raw = bytearray(mcap.read_bytes())
    a, b = spans[-1]
    raw[(a + b) // 2] ^= 0x10  # inside the last chunk's messages
    mcap.write_bytes(bytes(raw))
    ours, ref = _read_both(bag)
    assert calls[1:2] == [False]
    assert isinstance(ref, OptinavError) and isinstance(ours, OptinavError)
    assert "checksum" in str(ref)


def test_crc32_is_zlibs_by_either_library(tmp_path, monkeypatch):
    """bagscan.crc32 (libdeflate's where the system has it, zlib's otherwise) gives zlib's CRC-32 of bytes, a numpy
    array and a slice of a file map at odd offsets and lengths (the mcap chunk check compares it with the
    CRC the writer stored, computed by zlib's definition)."""
    import mmap
    import zlib

    from optinav.io import bagscan

    data = np.random.default_rng(41).integers(0, 256, 1_000_003, dtype=np.uint8)
    f = tmp_path / "d.bin"
    f.write_bytes(data.tobytes())
    with open(f, "rb") as fh:
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    u8 = np.frombuffer(mm, dtype=np.uint8)
    cases = [(0, 0), (0, 1), (3, 17), (5, 4096 + 3), (101, 1_000_003), (0, 1_000_003)]
    for lib in (bagscan._libdeflate_crc32(), None):
        monkeypatch.setattr(bagscan, "_libdeflate_crc32", lambda lib=lib: lib)
        for a, b in cases:
            want = zlib.crc32(data[a:b].tobytes())
            assert bagscan.crc32(u8[a:b]) == want and bagscan.crc32(data[a:b].tobytes()) == want, (lib, a, b)
    del u8
    mm.close()


def test_mcap_summary_contradicting_a_chunk_is_refused(tmp_path, capsys):
    """A Chunk Index whose message start time disagrees with its chunk's own header (one damaged byte of the
    summary): rosbags orders the chunks by the index's times and leaves thousands of messages out without a word
    (4048 of 7000 in the fuzz case that found it); optinav refuses, naming both times and the fix."""
    import struct

    from optinav.io import bagscan

    rng = np.random.default_rng(28)
    msgs, *_ = imu_topic(rng, n=7000, rate=1000.0)
    bag = write_bag(tmp_path / "s", "mcap", {"/imu": (IMU, msgs)})
    mcap = next(bag.glob("*.mcap"))
    raw = bytearray(mcap.read_bytes())
    with open(mcap, "rb") as fh:
        fh.seek(len(raw) - 8 - 29)
        tail = fh.read(29)
    pos = struct.unpack_from("<Q", tail, 9)[0]  # the summary's start
    while raw[pos] != 0x08:
        pos += 9 + struct.unpack_from("<Q", raw, pos + 1)[0]
    raw[pos + 9 + 6] ^= 0x40  # the first Chunk Index's message start time
    mcap.write_bytes(bytes(raw))
    ours, ref = _read_both(bag)
    assert isinstance(ref, dict) and ref["t"].size < 7000  # rosbags' silent loss
    assert isinstance(ours, bagscan.Damaged) and "its summary gives the chunk at byte" in str(ours)
    assert main(["allan", str(bag), "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert "mcap recover" in err and len(err.strip().splitlines()) == 1


def test_work_ahead_keeps_order_and_raises_in_place(monkeypatch):
    """:func:`bagscan._ahead`: results in the items' order whatever the threads' finishing order, an error of an
    item's work raised when that item comes (the items before it handed out), work not started dropped when the
    reader stops."""
    import time

    from optinav.io import bagscan

    spy = _SpyPool()
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    monkeypatch.setattr(bagscan, "_workers", lambda: 2)

    def work(item):
        time.sleep(0.002 * (item[0] % 3))
        if item[0] == 7:
            raise bagscan.NotFast("item 7")
        return item[0] * 10

    items = [(i, None, i % 2 == 0) for i in range(12)]
    got = []
    with pytest.raises(bagscan.NotFast, match="item 7"):
        for item, res in bagscan._ahead(iter(items), work, lambda it: it[2]):
            got.append((item[0], res))
    assert got == [(i, 10 * i) for i in range(7)]
    assert spy.jobs >= 4  # the even items went to the helpers
    gen = bagscan._ahead(iter(items[:6]), work, lambda it: True)
    assert next(gen) == (items[0], 0)
    gen.close()  # the rest dropped, no error


def test_mcap_summary_picks_chunks_and_its_absence_scans_them(tmp_path, monkeypatch):
    """MCAP: the summary's chunk index picks the chunks of the Imu topic (a first chunk of strings only is not
    read); with the footer's summary offset zeroed (no summary) every chunk is scanned. Same values either way."""
    import optinav.io.rosbag as rb
    from optinav.io import bagscan

    rng = np.random.default_rng(16)
    msgs, t, gyr, acc = imu_topic(rng, n=80)
    chatter = [(1_600_000_000 * 10**9 + k, lambda ts, k=k: ts.types[STR](data=str(k % 10) * 5000)) for k in range(300)]
    bag = write_bag(tmp_path / "m", "mcap-file", {"/chatter": (STR, chatter), "/imu": (IMU, msgs)})
    with open(bag, "rb") as fh:
        chans, offsets, _ = bagscan._mcap_index(fh, "/imu")
    assert len(chans) == 1 and 1 <= len(offsets) and offsets[0] > 1_000_000  # the chatter chunk is skipped
    monkeypatch.setattr(rb, "_rosbags_blocks", None)
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    raw = bytearray(bag.read_bytes())
    raw[-37 + 9 : -37 + 17] = bytes(8)  # Footer: summary_start = 0
    flat = tmp_path / "flat.mcap"
    flat.write_bytes(bytes(raw))
    with open(flat, "rb") as fh:
        assert bagscan._mcap_index(fh, "/imu") is None
    log = read_imu(flat)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


@pytest.mark.parametrize("kind", ("ros1", "mcap"))
def test_log_times_out_of_order_read_in_rosbags_order(tmp_path, kind):
    # log times written out of order (within and across chunks): rosbags yields log-time order, so does the scan
    rng = np.random.default_rng(12)
    msgs, *_ = imu_topic(rng, n=60)
    perm = rng.permutation(60)
    msgs = [(1_700_000_000 * 10**9 + 1_000_000 * int(perm[i]), make) for i, (_, make) in enumerate(msgs)]
    bag = write_bag(tmp_path / "o", kind, {"/imu": (IMU, msgs)})
    ref = rosbags_reference(bag, "/imu")
    with pytest.warns(UserWarning, match="not strictly increasing"):
        log = read_imu(bag)
    assert np.array_equal(log.gyr, ref[:, 1:4]) and np.array_equal(log.acc, ref[:, 4:7])


def test_big_endian_cdr_goes_through_the_deserializer(tmp_path):
    rng = np.random.default_rng(13)
    msgs, t, gyr, acc = imu_topic(rng, n=30)
    for big in ({0, 1, 2}, {5, 17}):  # the first message big-endian: no numpy layout at all; or a few of them
        bag = write_bag(tmp_path / f"be{len(big)}", "mcap", {"/imu": (IMU, msgs)}, big_endian=big)
        log = read_imu(bag)
        assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def test_scanner_failure_falls_back_to_rosbags(tmp_path, monkeypatch):
    from optinav.io import bagscan

    def refuse(kind, data):
        raise bagscan.NotFast("test")

    monkeypatch.setattr(bagscan, "_decompress", refuse)
    rng = np.random.default_rng(14)
    msgs, t, gyr, acc = imu_topic(rng, n=30)
    for kind in ("ros1", "mcap"):
        log = read_imu(write_bag(tmp_path / kind, kind, {"/imu": (IMU, msgs)}))
        assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def _libzstd():
    from optinav.io import bagscan

    return bagscan._libzstd() is not None


def _message_frames(monkeypatch, frame):
    """rosbags' writer compresses each message with ``frame(data) -> bytes`` (``--compression-mode message``)."""
    import rosbags.rosbag2.writer as w

    class Z:
        compress = staticmethod(frame)

    monkeypatch.setattr(w, "zstd", Z)


@pytest.mark.parametrize("kind", ("mcap", "sqlite3"))
def test_message_compressed_frames_without_content_size_or_damaged(tmp_path, monkeypatch, kind):
    """Messages compressed one by one: frames without a content size in their header are read through rosbags
    (the same values); a frame whose header states another size than it inflates to ends in a one-line error
    naming the topic, never in values shifted from one message into the next."""
    from optinav.io.bagscan import zstd_module

    zstd = zstd_module()
    rng = np.random.default_rng(17)
    msgs, t, gyr, acc = imu_topic(rng, n=50)
    no_size = {zstd.CompressionParameter.content_size_flag: 0}
    flush = zstd.ZstdCompressor.FLUSH_FRAME
    _message_frames(monkeypatch, lambda d: zstd.ZstdCompressor(options=no_size).compress(d, mode=flush))
    bag = write_bag(tmp_path / "n", kind, {"/imu": (IMU, msgs)}, compression="message")
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)

    calls = []

    def wrong_size(d):  # message 7 claims one byte more than it holds
        calls.append(d)
        f = bytearray(zstd.compress(d))
        if len(calls) == 8:
            assert f[4] & 0x23 == 0x20 and f[5] < 255  # single segment, no dictionary: the content size at byte 5
            f[5] += 1
        return bytes(f)

    _message_frames(monkeypatch, wrong_size)
    bag = write_bag(tmp_path / "w", kind, {"/imu": (IMU, msgs)}, compression="message")
    with pytest.raises(OptinavError, match="not a readable ROS bag: topic '/imu'"):
        read_imu(bag)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    sizes=st.lists(st.integers(0, 70_000), min_size=1, max_size=6),
    level=st.integers(1, 19),
    checksum=st.booleans(),
    with_size=st.lists(st.booleans(), min_size=6, max_size=6),
)
def test_zstd_frame_header_sizes(sizes, level, checksum, with_size):
    """The content size read from each frame header equals the codec's own (``get_frame_info``) for frames of
    every content-size field width (1, 2 and 4 bytes; single segment or with a window descriptor); the first frame
    without one is named."""
    from optinav.io import _bagkernels as kern
    from optinav.io.bagscan import zstd_module

    zstd = zstd_module()
    P = zstd.CompressionParameter
    frames = []
    for k, n in enumerate(sizes):
        data = np.random.default_rng(n).integers(0, 4, n, dtype=np.uint8).tobytes()
        opts = {P.compression_level: level, P.checksum_flag: int(checksum), P.content_size_flag: int(with_size[k])}
        frames.append(zstd.ZstdCompressor(options=opts).compress(data, mode=zstd.ZstdCompressor.FLUSH_FRAME))
    buf = np.frombuffer(b"".join(frames), dtype=np.uint8)
    size = np.array([len(f) for f in frames], dtype=np.int64)
    off = np.concatenate([[0], np.cumsum(size)[:-1]]).astype(np.int64)
    content = np.full(size.size, -7, dtype=np.int64)
    bad = kern.zstd_sizes(buf, off, size, content)
    known = [zstd.get_frame_info(f).decompressed_size for f in frames]
    first = next((i for i, c in enumerate(known) if c is None), -1)
    assert bad == first
    upto = len(known) if first < 0 else first
    assert content[:upto].tolist() == known[:upto] == sizes[:upto]


def test_sqlite_scan_reads_only_and_falls_back(tmp_path, monkeypatch):
    """A sqlite3 bag is read from its b-tree without rosbags' reader and never written (same bytes and time
    stamp after the read); Imu messages whose frame ids vary in length go through the deserializer one by one;
    a write-ahead log beside the database, or a scanner failure, hand the bag to rosbags with the same values."""
    import hashlib
    import os

    import optinav.io.rosbag as rb
    from optinav.io import bagscan

    rng = np.random.default_rng(18)
    msgs, t, gyr, acc = imu_topic(rng, n=500, rate=1000.0, frames=("imu",) * 7 + ("imu_long_frame_id",))
    chatter = [(1_700_000_000 * 10**9 + 3 * k, lambda ts, k=k: ts.types[STR](data="y" * (k % 50))) for k in range(200)]
    bag = write_bag(tmp_path / "s", "sqlite3-file", {"/chatter": (STR, chatter), "/imu": (IMU, msgs)})
    before = hashlib.sha256(bag.read_bytes()).hexdigest(), os.stat(bag).st_mtime_ns
    seen = []
    real = bagscan.sqlite_blocks

    def spy(*a):
        for b in real(*a):
            seen.append(b[1].size)
            yield b

    monkeypatch.setattr(bagscan, "sqlite_blocks", spy)
    with monkeypatch.context() as m:
        import rosbags.highlevel

        m.setattr(rosbags.highlevel, "AnyReader", None)
        m.setattr(rb, "_rosbags_blocks", None)
        log = read_imu(bag)
    assert sum(seen) == 500
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    assert (hashlib.sha256(bag.read_bytes()).hexdigest(), os.stat(bag).st_mtime_ns) == before
    seen.clear()
    wal = bag.with_name(bag.name + "-wal")
    wal.write_bytes(b"x")  # a log SQLite would replay: the file alone is not the database
    with pytest.raises(bagscan.NotFast, match="write-ahead"):
        next(real(bag, "/imu"))
    wal.unlink()

    def refuse(*a):
        raise bagscan.NotFast("test")
        yield

    monkeypatch.setattr(bagscan, "sqlite_blocks", refuse)
    log = read_imu(bag)  # through rosbags' reader and iteration
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


_DAMAGE = {}


def _damage_bags(tmp_path_factory):
    """One small ROS 1 bag and one MCAP file (Imu with two frame ids, MagneticField), written once."""
    if not _DAMAGE:
        d = tmp_path_factory.mktemp("damage")
        rng = np.random.default_rng(17)
        msgs, *_ = imu_topic(rng, n=40, frames=("imu",) * 5 + ("imu_x",))
        mags = [
            (
                1_700_000_000 * 10**9 + 10**7 * k,
                lambda ts, k=k: mag_msg(ts, 1_700_000_000, 10**7 * k, [1e-5, 2e-5, k * 1e-6]),
            )
            for k in range(8)
        ]
        for kind in ("ros1", "mcap-file", "sqlite3-file"):
            bag = write_bag(d / kind, kind, {"/imu": (IMU, msgs), "/mag": (MAG, mags)})
            _DAMAGE[kind] = (bag.suffix, bag.read_bytes())
    return _DAMAGE


def _read_both(path):
    """(read_table through the storage scanners, read_table through rosbags alone): each a dict or the error."""
    import optinav.io.rosbag as rb
    from optinav.io import bagscan

    out = []
    for scan in (True, False):
        saved = bagscan.blocks, rb._ros1_quick, rb._sqlite_quick, rb._whole, rb._inflated_twin
        if not scan:  # every path of optinav's own off: rosbags' reader and iteration alone
            bagscan.blocks, rb._ros1_quick, rb._sqlite_quick = (lambda *a: None), (lambda *a: None), (lambda *a: None)
            rb._whole, rb._inflated_twin = (lambda *a: False), (lambda *a: None)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                tab = read_table(path)
            # mz only when the magnetometer topic survived the damage (a damaged type name hides it from both)
            out.append({k: np.asarray(tab[k]) for k in ("t", "ax", "gy", "mz") if k in tab})
        except OptinavError as exc:
            out.append(exc)
        finally:
            bagscan.blocks, rb._ros1_quick, rb._sqlite_quick, rb._whole, rb._inflated_twin = saved
    return out


@settings(max_examples=40)
# a damaged timestamp in the sqlite3 table, which its index (what rosbags reads) contradicts
@example(kind="sqlite3-file", where=0.8203125, flip=1)
@given(
    kind=st.sampled_from(("ros1", "mcap-file", "sqlite3-file")),
    where=st.floats(0, 1, exclude_max=True),
    flip=st.integers(1, 255),
)
def test_damaged_byte_never_gives_other_values_than_rosbags(tmp_path_factory, kind, where, flip):
    """One byte of a bag changed anywhere: reading through the scanners gives a one-line error or the values
    rosbags gives (for sqlite3, unless the damage sets the table against its index: SQLite's integrity check
    says so); never another table, never a traceback."""
    suffix, raw = _damage_bags(tmp_path_factory)[kind]
    raw = bytearray(raw)
    raw[int(where * len(raw))] ^= flip
    path = tmp_path_factory.mktemp("d") / f"b{suffix}"
    path.write_bytes(bytes(raw))
    ours, ref = _read_both(path)
    if isinstance(ours, dict) and isinstance(ref, dict):
        same = ours.keys() == ref.keys() and all(np.array_equal(ours[k], ref[k], equal_nan=True) for k in ours)
        if not same and kind.startswith("sqlite3"):
            # the scanner reads the messages table, rosbags orders by the timestamp index: they may differ only
            # where the damage made the two disagree, which SQLite's own check reports
            import sqlite3

            con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
            try:
                same = con.execute("PRAGMA integrity_check").fetchall() != [("ok",)]
            finally:
                con.close()
        assert same, (ours, ref)


def test_many_messages_cross_the_decoding_blocks(tmp_path, monkeypatch):
    import optinav.io.rosbag as rb

    monkeypatch.setattr(rb, "_BLOCK", 7)
    rng = np.random.default_rng(3)
    msgs, t, gyr, acc = imu_topic(rng, n=50)
    bag = write_bag(tmp_path / "b", "mcap", {"/imu": (IMU, msgs)})
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def test_sqlite_arrays_grow_past_the_first_block_estimate(tmp_path, monkeypatch):
    """One leaf page per block and the strings first: the first block holds no Imu message, so the estimate the
    arrays start from is far below the topic's count; they grow and every value is there."""
    import rosbags.highlevel

    from optinav.io import bagscan

    rng = np.random.default_rng(19)
    msgs, t, gyr, acc = imu_topic(rng, n=400, rate=1000.0)
    chatter = [(1_600_000_000 * 10**9 + k, lambda ts, k=k: ts.types[STR](data="z" * 900)) for k in range(20)]
    bag = write_bag(tmp_path / "g", "sqlite3-file", {"/chatter": (STR, chatter), "/imu": (IMU, msgs)})
    monkeypatch.setattr(bagscan, "_LEAVES", 1)
    rows = []
    blocks = list(bagscan.sqlite_blocks(bag, "/imu", rows))
    assert rows and rows[0] < 400 and len(blocks) > 5
    monkeypatch.setattr(rosbags.highlevel, "AnyReader", None)  # read by the scanner alone
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def test_sqlite_interior_pages_walked_or_declined(tmp_path):
    """The messages table's interior pages walked to its leaves (every leaf once, in key order: the values
    written), and a damaged interior page — another page type, a cell pointer past its page — declined (NotFast:
    rosbags' reader then decides), not walked."""
    from optinav.io import bagscan

    rng = np.random.default_rng(29)
    msgs, t, gyr, acc = imu_topic(rng, n=3000, rate=1000.0)
    bag = write_bag(tmp_path / "i", "sqlite3-file", {"/imu": (IMU, msgs)})
    ids, root, psize = bagscan._sqlite_meta(bag, "/imu")
    mm, u8, leaves, *_ = bagscan.sqlite_leaves(bag, "/imu")
    assert u8[(root - 1) * psize] == 5 and leaves.size > 20 and np.unique(leaves).size == leaves.size
    assert all(u8[(p - 1) * psize] == 13 for p in leaves)
    del u8
    mm.close()
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    raw = bytearray(bag.read_bytes())
    for at, value, why in (((root - 1) * psize, 13 + 100, "not a table b-tree page"),
                           ((root - 1) * psize + 12, 0xFF, "a cell pointer outside its page")):  # fmt: skip
        bad = tmp_path / f"bad{at}.db3"
        damaged = bytearray(raw)
        damaged[at] = value
        bad.write_bytes(bytes(damaged))
        with pytest.raises(bagscan.NotFast, match=why):
            bagscan.sqlite_leaves(bad, "/imu")


def test_sqlite_pages_decoded_in_rounds_and_grown(tmp_path, monkeypatch):
    """sqlite3 bags decoded page block by page block in one compiled call per round: the strings first (the
    first blocks hold no Imu message), one leaf page per block, rounds of three pages, arrays grown from a low
    estimate: every value written; a message of another layout declines (the blocks read it, same values)."""
    import rosbags.highlevel

    from optinav.io import bagscan

    rng = np.random.default_rng(25)
    msgs, t, gyr, acc = imu_topic(rng, n=400, rate=1000.0)
    chatter = [(1_600_000_000 * 10**9 + k, lambda ts, k=k: ts.types[STR](data="z" * 900)) for k in range(20)]
    bag = write_bag(tmp_path / "g", "sqlite3-file", {"/chatter": (STR, chatter), "/imu": (IMU, msgs)})
    monkeypatch.setattr(bagscan, "_LEAVES", 1)
    monkeypatch.setattr(bagscan, "_ROUND", 3 * 4096)
    monkeypatch.setattr(rosbags.highlevel, "AnyReader", None)  # read by the scanner alone
    calls = _spy_decode(monkeypatch, "sqlite_decode")
    grown = []
    import optinav.io.rosbag as rb

    resize = rb._Decoder._resize
    monkeypatch.setattr(rb._Decoder, "_resize", lambda self, n: grown.append(n) or resize(self, n))
    log = read_imu(bag)
    assert calls == [400] and len(grown) >= 2
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    frames = ("imu",) * 300 + ("imu_link_long",) + ("imu",) * 99
    msgs, t, gyr, acc = imu_topic(rng, n=400, rate=1000.0, frames=frames)
    bag = write_bag(tmp_path / "h", "sqlite3-file", {"/imu": (IMU, msgs)})
    log = read_imu(bag)
    assert calls[1:] == [None]
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


@pytest.mark.parametrize("leaves,pages,slow", [(1, 6, "main"), (2, 7, "helper")])  # pages per block, per batch
def test_sqlite_batches_taken_by_two_threads(tmp_path, monkeypatch, leaves, pages, slow):
    """sqlite3 leaf pages in batches taken by whichever of two threads is free, each decoded into the output after
    the cells of the batches before it (moved down where other topics' cells were among them): every page once,
    most by the thread not slowed; the Imu and MagneticField values of the one-thread reading, exactly; log times
    out of order across the pages still read in rosbags' order (the order across the batches is checked)."""
    import rosbags.highlevel

    from optinav.io import bagscan

    rng = np.random.default_rng(27)
    msgs, t, gyr, acc = imu_topic(rng, n=600, rate=1000.0)
    mags = [(1_700_000_000 * 10**9 + 10**7 * k + 3, lambda ts, k=k: mag_msg(ts, 1_700_000_000, 10**7 * k, rng.normal(0, 1e-5, 3))) for k in range(60)]  # fmt: skip
    bag = write_bag(tmp_path / "s", "sqlite3-file", {"/imu": (IMU, msgs), "/mag": (MAG, mags)})
    any_reader = rosbags.highlevel.AnyReader
    monkeypatch.setattr(rosbags.highlevel, "AnyReader", None)  # read by the scanner alone
    monkeypatch.setattr(bagscan, "_helper", lambda: None)
    one = read_table(bag)
    monkeypatch.setattr(bagscan, "_LEAVES", leaves)
    monkeypatch.setattr(bagscan, "_ROUND", pages * 4096)
    spy = _SpyPool()
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    calls = _spy_decode(monkeypatch, "sqlite_decode")
    seen = _spy_threads(monkeypatch, "sqlite_decode", slow=slow)
    two = read_table(bag)
    assert calls == [600, 60] and spy.jobs >= 2  # one per topic and pass (the output grown between)
    for k in one:
        assert np.array_equal(two[k], one[k], equal_nan=True), k
    n = len(seen) // 2  # the Imu topic's batches, then the MagneticField's: the same pages
    for topic in (seen[:n], seen[n:]):
        got = [p for _, ps in topic for p in ps]
        assert len(got) == len(set(got)) >= 20  # every leaf page once
        assert sum(m != (slow == "main") for m, _ in topic) >= 0.6 * len(topic), (slow, [m for m, _ in topic])
    assert np.array_equal(two["t"], t) and np.array_equal(two["gx"], gyr[:, 0])
    # log times permuted: declined by the order checks, read in rosbags' order
    monkeypatch.setattr(rosbags.highlevel, "AnyReader", any_reader)
    perm = rng.permutation(600)
    shuffled = [(1_700_000_000 * 10**9 + 1_000_000 * int(perm[i]), make) for i, (_, make) in enumerate(msgs)]
    bag = write_bag(tmp_path / "o", "sqlite3-file", {"/imu": (IMU, shuffled)})
    ref = rosbags_reference(bag, "/imu")
    with pytest.warns(UserWarning, match="not strictly increasing"):
        log = read_imu(bag)
    assert calls[2:] == [None]
    assert np.array_equal(log.gyr, ref[:, 1:4]) and np.array_equal(log.acc, ref[:, 4:7])


def test_sqlite_batch_count_that_fails_stops_both_threads(tmp_path, monkeypatch):
    """A batch whose cell count raises (the other thread may be waiting for that count to place its own batch) stops
    both threads instead of leaving one waiting: the read falls back to the blocks, the values those written."""
    import rosbags.highlevel

    from optinav.io import _bagkernels as kern
    from optinav.io import bagscan

    rng = np.random.default_rng(31)
    msgs, t, gyr, acc = imu_topic(rng, n=600, rate=1000.0)
    bag = write_bag(tmp_path / "f", "sqlite3-file", {"/imu": (IMU, msgs)})
    monkeypatch.setattr(rosbags.highlevel, "AnyReader", None)  # read by the scanner alone
    monkeypatch.setattr(bagscan, "_LEAVES", 1)
    monkeypatch.setattr(bagscan, "_ROUND", 2 * 4096)
    monkeypatch.setattr(bagscan, "_helper", lambda: _SpyPool())
    real, calls = kern.sqlite_cells, []

    def count(*args):
        calls.append(1)
        if len(calls) == 4:
            raise RuntimeError("a count that fails")
        return real(*args)

    monkeypatch.setattr(kern, "sqlite_cells", count)
    decoded = _spy_decode(monkeypatch, "sqlite_decode")
    log = read_imu(bag)
    assert decoded == [] and len(calls) >= 4  # it raised: the caller reads the blocks
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def _imu_mag_sqlite_in_small_rounds(tmp_path, monkeypatch, msgs, mags, pages: int):
    """A rosbag2 sqlite3 bag of the Imu messages ``msgs`` and MagneticField messages ``mags`` ((stamp ns, maker)
    pairs) interleaved by stamp, to be read by the scanner alone in rounds of ``pages`` pages of one leaf each and
    one thread (the caller hands it a helper after its first reading); its path."""
    import rosbags.highlevel

    from optinav.io import bagscan

    merged = sorted([(ts, "/imu", m) for ts, m in msgs] + [(ts, "/mag", m) for ts, m in mags], key=lambda x: x[0])
    w = Writer2(tmp_path / "s", version=9, storage_plugin=StoragePlugin.SQLITE3)
    with w:
        cons = {name: w.add_connection(name, typ, typestore=TS2) for name, typ in (("/imu", IMU), ("/mag", MAG))}
        for ts, name, make in merged:
            w.write(cons[name], ts, TS2.serialize_cdr(make(TS2), IMU if name == "/imu" else MAG))
    monkeypatch.setattr(rosbags.highlevel, "AnyReader", None)
    monkeypatch.setattr(bagscan, "_LEAVES", 1)
    monkeypatch.setattr(bagscan, "_ROUND", pages * 4096)
    monkeypatch.setattr(bagscan, "_helper", lambda: None)
    return next((tmp_path / "s").glob("*.db3"))


def test_sqlite_batches_placed_by_cell_counts_equal_one_thread(tmp_path, monkeypatch):
    """sqlite3 batches of leaf pages, each decoded by either thread after the cells of the batches before it and
    moved down onto its rows: with Imu and MagneticField messages interleaved in bursts (leaf pages holding both
    topics' cells, in varying shares), odd counts, and the first pages without Imu messages (the estimate too low:
    the batches past the reservation are decoded after the others in one thread, the output grown), the arrays of
    the one-thread reading, exactly, and the values written."""
    import optinav.io.rosbag as rb

    from optinav.io import bagscan

    rng = np.random.default_rng(43)
    msgs, t, gyr, acc = imu_topic(rng, n=1001, rate=1000.0)
    t0 = 1_700_000_000 * 10**9
    # 37 magnetometer messages before the first Imu message, then bursts of 1-9 at random times
    tm = np.sort(np.concatenate([np.arange(37), rng.choice(np.arange(50, 100_000), 263, replace=False)]) * 10_000)
    bm = rng.normal(0, 1e-5, (tm.size, 3))
    mags = [(t0 + int(x), lambda ts, k=k: mag_msg(ts, 1_700_000_000, int(tm[k]), bm[k])) for k, x in enumerate(tm)]
    bag = _imu_mag_sqlite_in_small_rounds(tmp_path, monkeypatch, msgs, mags, 7)
    one = read_table(bag)
    spy = _SpyPool()
    monkeypatch.setattr(bagscan, "_helper", lambda: spy)
    calls = _spy_decode(monkeypatch, "sqlite_decode")
    grown = []
    resize = rb._Decoder._resize
    monkeypatch.setattr(rb._Decoder, "_resize", lambda self, n: grown.append(n) or resize(self, n))
    seen = _spy_threads(monkeypatch, "sqlite_decode")
    two = read_table(bag)
    assert calls == [1001, 300] and spy.jobs >= 2 and len(grown) >= 3  # the first reservation, then growth
    assert sum(not m for m, _ in seen) >= 2  # the helper took batches
    for k in one:
        assert np.array_equal(two[k], one[k], equal_nan=True), k
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def test_offsets_outside_a_block_fall_back_to_rosbags(tmp_path, monkeypatch):
    """A scanner handing out a message past its block's bytes is never read past: rosbags reads the topic."""
    from optinav.io import bagscan

    real = bagscan.blocks

    def shifted(*a):
        out = real(*a)
        return None if out is None else ((buf, off + len(buf), size, logt) for buf, off, size, logt in out)

    monkeypatch.setattr(bagscan, "blocks", shifted)
    rng = np.random.default_rng(20)
    msgs, t, gyr, acc = imu_topic(rng, n=30)
    log = read_imu(write_bag(tmp_path / "m", "mcap", {"/imu": (IMU, msgs)}))
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def test_mcap_log_time_outside_its_chunk_goes_to_rosbags(tmp_path):
    """One Imu message's log time moved past its chunk's message span: the scanner refuses the chunk and the
    values are rosbags' own (its reader of record), whatever it makes of the contradiction."""
    import struct

    from optinav.io import bagscan

    rng = np.random.default_rng(21)
    msgs, *_ = imu_topic(rng, n=30)
    bag = write_bag(tmp_path / "s", "mcap-file", {"/imu": (IMU, msgs)})
    raw = bytearray(bag.read_bytes())
    with open(bag, "rb") as fh:
        chans, offsets, _ = bagscan._mcap_index(fh, "/imu")
    start = offsets[0] + 9
    end_time = struct.unpack_from("<Q", raw, start + 8)[0]
    p = start + 32 + struct.unpack_from("<I", raw, start + 28)[0] + 8  # the chunk's first record
    while raw[p] != 0x05:
        p += 9 + struct.unpack_from("<Q", raw, p + 1)[0]
    struct.pack_into("<Q", raw, p + 15, end_time + 10**9)  # the first message's log time, 1 s past the span
    bag.write_bytes(bytes(raw))
    with pytest.raises(bagscan.NotFast, match="span"):
        list(bagscan._mcap(bag, "/imu"))
    ours, ref = _read_both(bag)
    if isinstance(ours, dict) and isinstance(ref, dict):
        assert ours.keys() == ref.keys() and all(np.array_equal(ours[k], ref[k]) for k in ours)
    else:
        assert isinstance(ours, OptinavError) and isinstance(ref, OptinavError)


def test_triad_shares_only_an_n_by_3_array():
    """read_imu takes the columns of one row-major (n, 3) array back whole; other columns are stacked copies."""
    from optinav.io.imu import _triad

    x = np.arange(30.0).reshape(10, 3)
    got, bounds, _ = _triad([x[:, 0], x[:, 1], x[:, 2]])
    assert np.array_equal(got, x) and np.shares_memory(got, x) and bounds is None
    got, _, _ = _triad([x[:4, 0], x[:4, 1], x[:4, 2]])
    assert got.shape == (4, 3) and np.array_equal(got, x[:4])
    wide = np.arange(70.0).reshape(10, 7)
    for cols in ([wide[:, 1], wide[:, 2], wide[:, 3]], [x[:, 1], x[:, 0], x[:, 2]], [x[:, 0], x[:, 1], x[:, 1]]):
        got, _, _ = _triad(cols)
        assert np.array_equal(got, np.column_stack(cols)) and not any(np.shares_memory(got, c) for c in cols)


def test_topic_choice(tmp_path):
    rng = np.random.default_rng(4)
    m1, t1, g1, a1 = imu_topic(rng)
    m2, t2, g2, a2 = imu_topic(rng, n=20)
    bag = write_bag(
        tmp_path / "b",
        "sqlite3",
        {
            "/imu/left": (IMU, m1),
            "/imu/right": (IMU, m2),
            "/chatter": (STR, [(1, lambda ts: ts.types[STR](data="hi"))]),
        },
    )
    with pytest.raises(OptinavError, match=r"has 2 sensor_msgs/msg/Imu topics .*/imu/left .*/imu/right.*--topic"):
        read_imu(bag)
    log = read_imu(bag, topic="/imu/right")
    assert np.array_equal(log.gyr, g2) and np.array_equal(log.t, t2)
    with pytest.raises(OptinavError, match=r"no topic '/imu/middle' \(topics: /imu/left \(sensor_msgs/Imu, 40 msgs"):
        read_imu(bag, topic="/imu/middle")
    with pytest.raises(OptinavError, match=r"'/chatter' of b holds std_msgs/msg/String, not sensor_msgs/msg/Imu"):
        read_imu(bag, topic="/chatter")
    with pytest.raises(OptinavError, match="holds sensor_msgs/msg/Imu, not sensor_msgs/msg/MagneticField"):
        read_imu(bag, topic="/imu/left,/imu/right")
    csv = tmp_path / "x.csv"
    csv.write_text("t,ax\n0,1\n1,2\n")
    with pytest.raises(OptinavError, match="applies to ROS bags"):
        read_table(csv, topic="/imu")
    # read in blocks (calibrate accel, allan) the text file ignored --topic
    csv.write_text("t,ax,ay,az\n0,0,0,9.8\n0.01,0,0,9.8\n")
    assert len(list(iter_imu(csv, chunk_rows=1))) == 2
    with pytest.raises(OptinavError, match="a topic applies to ROS bags, not to x.csv"):
        list(iter_imu(csv, topic="/imu", chunk_rows=1))


def test_no_imu_topic_and_empty_topic(tmp_path):
    bag = write_bag(tmp_path / "s", "ros1", {"/chatter": (STR, [(1, lambda ts: ts.types[STR](data="hi"))])})
    with pytest.raises(OptinavError, match="has no sensor_msgs/msg/Imu topics.*record the IMU"):
        read_imu(bag)
    empty = write_bag(tmp_path / "e", "sqlite3", {"/imu": (IMU, [])})
    with pytest.raises(OptinavError, match="'/imu' of e holds no messages"):
        read_imu(empty)


def test_zero_stamps_use_log_time(tmp_path):
    rng = np.random.default_rng(5)
    msgs, t, gyr, acc = imu_topic(rng, n=10, stamps=np.zeros(10, np.int64), t0=0)
    logt = 1_700_000_000 * 10**9 + 10_000_000 * np.arange(10)
    msgs = [(int(logt[i]), make) for i, (_, make) in enumerate(msgs)]
    bag = write_bag(tmp_path / "z", "mcap", {"/imu": (IMU, msgs)})
    with pytest.warns(UserWarning, match="header stamps of '/imu' are zero; using the bag's log times"):
        log = read_imu(bag)
    np.testing.assert_array_equal(log.t, logt * 1e-9)
    assert np.array_equal(log.acc, acc)


def test_stamps_backwards_use_log_time(tmp_path):
    rng = np.random.default_rng(6)
    ns = (np.arange(12) * 10_000_000)[::-1].copy()
    msgs, t, gyr, acc = imu_topic(rng, n=12, stamps=ns)
    msgs = [(1_700_000_000 * 10**9 + 10_000_000 * i, make) for i, (_, make) in enumerate(msgs)]
    bag = write_bag(tmp_path / "r", "ros1", {"/imu": (IMU, msgs)})
    with pytest.warns(UserWarning, match="not strictly increasing"):
        log = read_imu(bag)
    np.testing.assert_array_equal(log.t, (1_700_000_000 * 10**9 + 10_000_000 * np.arange(12)) * 1e-9)
    assert np.array_equal(log.gyr, gyr)


def _mag_of(imu):
    """A MagneticField message with the Imu message's header and its angular velocity × 1e-5 T."""
    w = imu.angular_velocity
    return mag_msg(TS2, imu.header.stamp.sec, imu.header.stamp.nanosec, [w.x * 1e-5, w.y * 1e-5, w.z * 1e-5])


@pytest.mark.parametrize("kind", ("ros1", "sqlite3", "mcap"))
def test_messages_recorded_twice_are_left_out(tmp_path, kind):
    """One publisher recorded on two connections (or a message resent): every copy was a sample of its own, on
    the bag's log times, with a warning that named the stamps only (100 rows of 50 samples, exit 0). The copies
    (same stamp, same values) are left out, named, and the header stamps are the time; the blocks agree."""
    rng = np.random.default_rng(41)
    msgs, t, gyr, acc = imu_topic(rng, n=200)
    if kind == "ros1":  # the same message on a second connection, logged 1 µs later (or at the same time)
        bag = tmp_path / "twice.bag"
        with Writer1(bag) as w:
            w.chunk_threshold = 4096
            cons = [w.add_connection("/imu", IMU, typestore=TS1, callerid=c) for c in ("/a", "/b")]
            for i, (t_ns, make) in enumerate(msgs):
                raw = TS1.serialize_ros1(make(TS1), IMU)
                w.write(cons[0], t_ns, raw)
                w.write(cons[1], t_ns + 1000 * (i % 2), raw)
        copies = 200
    else:  # Imu messages 20 and 150 resent, and MagneticField message 3 (left out too)
        twice = [m for i, m in enumerate(msgs) for _ in range(2 if i in (20, 150) else 1)]
        mags = [(t_ns + 1000, lambda ts, m=m: _mag_of(m(ts))) for t_ns, m in msgs[::4]]
        bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, twice), "/mag": (MAG, mags[:4] + mags[3:])})
        copies = 2
    with pytest.warns(UserWarning, match=f"{copies} of the {200 + copies} messages of '/imu' repeat an earlier"):
        log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    with pytest.warns(UserWarning, match="repeat an earlier"):
        _, joined = _joined_tables(bag, 64)
    assert np.array_equal(joined["t"], t) and np.array_equal(joined["gx"], gyr[:, 0])
    if kind != "ros1":  # the magnetometer at the Imu stamps it shares: its values
        assert np.array_equal(joined["mx"][:160:4], gyr[:160:4, 0] * 1e-5)
    # a repeated stamp with other values is no copy: the log times, and the warning says what the stamps do
    other = [(t_ns, make) for t_ns, make in msgs]
    other.insert(31, (msgs[30][0] + 1000, lambda ts: imu_msg(ts, 1_700_000_000, 300_000_123, [1, 2, 3], [4, 5, 6])))
    bag = write_bag(tmp_path / "o", "mcap", {"/imu": (IMU, other)})
    with pytest.warns(UserWarning, match=r"not strictly increasing \(1 of 201 equal to the one before\)"):
        log = read_imu(bag)
    assert len(log) == 201 and np.array_equal(log.t, np.array([m[0] for m in other]) * 1e-9)


def test_two_publishers_on_one_ros1_topic(tmp_path, monkeypatch):
    """Two IMU drivers publishing /imu at once, stamps interleaved 2 ms apart: read as one IMU at twice the rate,
    no warning, exit 0. Refused, naming both callerids (by the storage scan and by rosbags' reader alike); one
    driver restarted under another name (one connection after the other) reads as one topic."""
    from optinav.io import bagscan

    rng = np.random.default_rng(43)
    msgs, t, gyr, acc = imu_topic(rng, n=60)
    other, *_ = imu_topic(rng, n=60, stamps=np.round(np.arange(60) / 100 * 1e9).astype(np.int64) + 2_000_123)

    def bag(name, pick):
        with Writer1(tmp_path / name) as w:
            w.chunk_threshold = 2048
            cons = [w.add_connection("/imu", IMU, typestore=TS1, callerid=c) for c in ("/imu_a", "/imu_b")]
            for c, (t_ns, make) in pick:
                w.write(cons[c], t_ns, TS1.serialize_ros1(make(TS1), IMU))
        return tmp_path / name

    both = bag("both.bag", [x for i in range(60) for x in ((0, msgs[i]), (1, other[i]))])
    restart = bag("restart.bag", [(int(i >= 25), m) for i, m in enumerate(msgs)])
    for scan in (True, False):
        if not scan:
            monkeypatch.setattr(bagscan, "ros1_index", lambda path: (_ for _ in ()).throw(bagscan.NotFast("test")))
        with pytest.raises(
            OptinavError, match="published by 2 connections whose messages interleave.*/imu_a and /imu_b"
        ):
            read_imu(both)
        with pytest.raises(OptinavError, match="messages interleave"):
            _joined_tables(both, 16)
        log = read_imu(restart)
        assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


@pytest.mark.parametrize("kind", KINDS + ("mcap-message",))
def test_two_imus_on_one_topic_by_frame_id(tmp_path, kind):
    """Two IMUs (frame_ids imu0/imu1, one connection: rosbag2 keeps no publisher per message, a ROS 1 node may
    publish both) on /imu at 100 Hz, stamps 3 ms apart: read as one IMU at 200 Hz with exit 0, its gyro and
    accelerometer alternating between two sensors. Refused naming both frame_ids (also when their names differ
    in length: the deserializer's path); ``--topic /imu@imu1`` reads that one. A driver restarted under another
    frame_id (one run, then the other) still reads as one IMU."""
    rng = np.random.default_rng(45)
    for names in (("imu0", "imu1"), ("imu0", "imu_right")):
        a, ta, gyr_a, acc_a = imu_topic(rng, n=300, frames=(names[0],))
        b, tb, gyr_b, acc_b = imu_topic(
            rng, n=300, frames=(names[1],), stamps=np.round(np.arange(300) / 100 * 1e9).astype(np.int64) + 3_000_123
        )
        both = sorted(a + b, key=lambda m: m[0])
        comp = "message" if kind == "mcap-message" else None
        bag = write_bag(tmp_path / f"b{len(names[1])}", kind.removesuffix("-message"), {"/imu": (IMU, both)}, comp)
        with pytest.raises(OptinavError, match=rf"2 header frame_ids \('{names[0]}' \(300 msgs\), '{names[1]}'"):
            read_imu(bag)
        with pytest.raises(OptinavError, match="frame_ids"):
            _joined_tables(bag, 64)
        log = read_imu(bag, topic=f"/imu@{names[1]}")
        assert np.array_equal(log.t, tb) and np.array_equal(log.gyr, gyr_b) and np.array_equal(log.acc, acc_b)
        with pytest.raises(OptinavError, match=r"no message with frame_id 'imu2'.*--topic /imu@FRAME"):
            read_imu(bag, topic="/imu@imu2")
    msgs, t, gyr, acc = imu_topic(rng, n=300, frames=("imu0", "imu_right"))
    bag = write_bag(tmp_path / "restart", kind.removesuffix("-message"), {"/imu": (IMU, msgs)})
    log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


def test_two_imus_on_one_topic_from_the_command_line(tmp_path, capsys):
    rng = np.random.default_rng(46)
    a, *_ = imu_topic(rng, n=300, frames=("imu0",))
    b, *_ = imu_topic(rng, n=300, frames=("imu1",), stamps=np.round(np.arange(300) / 100 * 1e9).astype(np.int64) + 3e6)
    bag = write_bag(tmp_path / "b", "mcap", {"/imu": (IMU, sorted(a + b, key=lambda m: m[0]))})
    assert main(["allan", str(bag), "--out", str(tmp_path / "n.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--topic /imu@imu0" in err and "'imu1' (300 msgs)" in err


@pytest.mark.parametrize("kind", ("ros1", "mcap", "sqlite3"))
def test_messages_logged_out_of_stamp_order(tmp_path, kind):
    """Valid stamps, but 1 message in 10 delivered 25 ms late (best-effort transport): the stamps were judged
    not increasing and the topic went to the log times (receive jitter on every sample, values out of order) with
    exit 0. Read in stamp order with a warning; the same for the magnetometer. A clock that jumps back 60 s is
    not reordered (the log times decide, as before)."""
    rng = np.random.default_rng(47)
    n = 400
    msgs, t, gyr, acc = imu_topic(rng, n=n, rate=200.0)
    delay = np.full(n, 2_000_000) + rng.integers(0, 500_000, n)
    delay[rng.choice(n, n // 10, replace=False)] += 25_000_000
    logt = np.array([m[0] for m in msgs]) - 5_000_000 + delay
    tm = 1_700_000_000 + np.arange(0, 2.0, 0.05)
    bm = rng.normal(0, 3e-5, (tm.size, 3))
    mlog = np.round(tm * 1e9).astype(np.int64) + 2_000_000
    mlog[3] += 80_000_000
    mags = [
        (int(mlog[k]), lambda ts, k=k: mag_msg(ts, int(tm[k]), round((tm[k] % 1) * 1e9), bm[k])) for k in range(tm.size)
    ]
    order, morder = np.argsort(logt, kind="stable"), np.argsort(mlog, kind="stable")
    topics = {
        "/imu": (IMU, [(int(logt[i]), msgs[i][1]) for i in order]),
        "/mag": (MAG, [mags[k] for k in morder]),
    }
    bag = write_bag(tmp_path / "b", kind, topics)
    for read in (read_table, lambda b: _joined_tables(b, 64)[1]):
        with pytest.warns(UserWarning, match=r"of the 400 messages of '/imu' were logged out of their header stamps"):
            tab = read(bag)
        assert np.array_equal(tab["t"], t)
        assert np.array_equal(np.column_stack([tab["gx"], tab["gy"], tab["gz"]]), gyr)
        np.testing.assert_allclose(tab["mx"][:300], np.interp(t, tm, bm[:, 0])[:300], rtol=0, atol=1e-18)
    back, *_ = imu_topic(rng, n=100, t0=1_700_000_000 - 60)
    msgs2 = msgs[:100] + [(msgs[99][0] + 10_000_000 * (k + 1), m[1]) for k, m in enumerate(back)]
    bag = write_bag(tmp_path / "jump", kind, {"/imu": (IMU, msgs2)})
    with pytest.warns(UserWarning, match="using the bag's log times"):
        log = read_imu(bag)
    assert np.array_equal(log.t, np.array([m[0] for m in msgs2]) * 1e-9)


def test_log_times_that_repeat_cannot_replace_the_stamps(tmp_path):
    """Zero stamps and a recorder on a simulated clock (four messages logged at each 10 ms tick): the error was a
    'duplicate timestamp' in a time column with --columns/--rate as the remedy, neither of which a bag takes."""
    rng = np.random.default_rng(44)
    msgs, *_ = imu_topic(rng, n=200, stamps=np.zeros(200, np.int64), t0=0)
    tick = 1_700_000_000 * 10**9 + 10_000_000 * (np.arange(200) // 4)
    bag = write_bag(tmp_path / "s", "mcap", {"/imu": (IMU, [(int(tick[i]), m) for i, (_, m) in enumerate(msgs)])})
    for read in (read_imu, lambda b: _joined_tables(b, 64)):
        with pytest.raises(OptinavError, match=r"are zero, and the bag's log times cannot replace them: 150 of 200"):
            read(bag)


@pytest.mark.parametrize("kind", ("ros1", "sqlite3", "mcap"))
def test_values_marked_not_measured_are_not_read(tmp_path, kind):
    """An accelerometer-only unit publishing sensor_msgs/Imu with angular_velocity_covariance[0] = -1 ('no such
    data') and zeros as its angular velocity: read as a gyroscope at rest, `optinav attitude` gave an attitude with
    exit 0. The group is left out (with a warning), whole and in blocks; so is one NaN in every message."""
    rng = np.random.default_rng(46)
    msgs, t, gyr, acc = imu_topic(rng, n=200)

    def marked(make, group, fill):
        def build(ts):
            msg = make(ts)
            setattr(msg, f"{group}_covariance", np.r_[-1.0, np.zeros(8)])
            V = ts.types["geometry_msgs/msg/Vector3"]
            setattr(msg, group, V(fill, fill, fill))
            return msg

        return build

    for group, fill in (("angular_velocity", 0.0), ("linear_acceleration", np.nan)):
        bag = write_bag(
            tmp_path / f"{group}", kind, {"/imu": (IMU, [(t_ns, marked(m, group, fill)) for t_ns, m in msgs])}
        )
        with pytest.warns(UserWarning, match=f"marks its {group.replace('_', ' ')} as not measured"):
            log = read_imu(bag)
        with pytest.warns(UserWarning, match="not measured"):
            blocks = list(iter_imu(bag, chunk_rows=64))
        for got in (log, blocks[0]):
            assert (got.gyr is None) == (group == "angular_velocity") and (got.acc is None) != (got.gyr is None)
        assert np.array_equal(log.t, t) and len(blocks) == 4
        assert np.array_equal(log.acc, acc) if log.acc is not None else np.array_equal(log.gyr, gyr)


@pytest.mark.parametrize("kind", ("ros1", "sqlite3", "mcap"))
def test_an_empty_magnetometer_topic_nobody_named(tmp_path, kind):
    """A magnetometer advertised but never published: the bag could not be read at all, even with --topic /imu
    ("topic '/mag' holds no messages; pass a topic with messages"). The Imu topic alone now; named, it is refused."""
    rng = np.random.default_rng(47)
    msgs, t, gyr, acc = imu_topic(rng, n=100)
    bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs), "/mag": (MAG, [])})
    for topic in (None, "/imu"):
        tab = read_table(bag, topic=topic)
        assert "mx" not in tab and np.array_equal(tab["t"], t) and np.array_equal(tab["gz"], gyr[:, 2])
        _, joined = _joined_tables(bag, 16, topic=topic)
        assert "mx" not in joined and np.array_equal(joined["ax"], acc[:, 0])
    with pytest.raises(OptinavError, match="topic '/mag' of b.* holds no messages"):
        read_table(bag, topic="/imu,/mag")


def test_ros1_stamps_after_2038(tmp_path, monkeypatch):
    """ROS 1 time is uint32 seconds; rosbags' deserializer reads int32, so stamps after 2038-01-19 were negative
    and the topic went to the log times (the compiled gather reads uint32, but its check against rosbags failed)."""
    from optinav.io import bagscan

    rng = np.random.default_rng(48)
    msgs, t, gyr, acc = imu_topic(rng, n=30, t0=0, frames=("imu", "ab"))
    t0 = 2_200_000_000
    bag = tmp_path / "y.bag"
    with Writer1(bag) as w:
        con = w.add_connection("/imu", IMU, typestore=TS1)
        for t_ns, make in msgs:
            raw = bytearray(TS1.serialize_ros1(make(TS1), IMU))
            raw[4:8] = (int.from_bytes(raw[4:8], "little") + t0).to_bytes(4, "little")  # header.stamp.sec
            w.write(con, t0 * 10**9 + t_ns, bytes(raw))
    log = read_imu(bag)
    assert np.array_equal(log.t, t + t0) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)
    monkeypatch.setattr(bagscan, "ros1_index", lambda path: (_ for _ in ()).throw(bagscan.NotFast("test")))
    assert np.array_equal(read_imu(bag).t, t + t0)


def test_batch_takes_a_ros2_bag_folder_as_one_unit(tmp_path):
    """`optinav batch` over a folder of recordings left ROS 2 bag folders out with no word (1 of 3 units, exit 0):
    a folder with metadata.yaml is one unit, identified for resume by its files' size and newest mtime."""
    import os

    from optinav.batch import find_units

    rng = np.random.default_rng(49)
    msgs, *_ = imu_topic(rng, n=50)
    d = tmp_path / "units"
    d.mkdir()
    write_bag(d / "a", "ros1", {"/imu": (IMU, msgs)})
    for kind in ("sqlite3", "mcap"):
        write_bag(d / kind, kind, {"/imu": (IMU, msgs)})
    (d / "notes").mkdir()
    units = find_units(d)
    assert [(u.name, u.path.name) for u in units] == [("a", "a.bag"), ("mcap", "mcap"), ("sqlite3", "sqlite3")]
    files = list((d / "mcap").iterdir())
    assert units[1].size == sum(f.stat().st_size for f in files)
    before = units[1].mtime_ns
    os.utime(files[0], ns=(before + 10**9, before + 10**9))
    assert find_units(d)[1].mtime_ns == before + 10**9


def test_allan_kalibr_rostopic_is_the_bags_topic(tmp_path):
    """`optinav allan BAG --kalibr` wrote the placeholder rostopic /imu0 (with a note) though the bag names its
    topic: Kalibr then looks for a topic the bag does not hold. The bag's Imu topic now; --rostopic still wins."""
    rng = np.random.default_rng(50)
    n = 3000
    ns = np.arange(n, dtype=np.int64) * 10_000_000
    gyr, acc = rng.normal(0, 1e-3, (n, 3)), rng.normal(0, 1e-2, (n, 3)) + [0, 0, 9.81]
    msgs = [
        (
            int(1_700_000_000 * 10**9 + ns[i]),
            lambda ts, i=i: imu_msg(ts, 1_700_000_000 + ns[i] // 10**9, ns[i] % 10**9, gyr[i], acc[i]),
        )
        for i in range(n)
    ]
    bag = write_bag(tmp_path / "s", "ros1", {"/imu_raw": (IMU, msgs)})
    for extra, topic in (([], "/imu_raw"), (["--rostopic", "/cam0/imu"], "/cam0/imu")):
        yaml = tmp_path / f"imu{len(extra)}.yaml"
        argv = ["--quiet", "allan", str(bag), "--out", str(tmp_path / f"a{len(extra)}.json"), "--kalibr", str(yaml)]
        assert main(argv + extra) == 0
        assert f"rostopic: {topic}\n" in yaml.read_text()


def test_stamp_faults_are_named(tmp_path):
    """A first stamp of zero (simulated time starting at 0) or negative stamps were called 'not strictly
    increasing', which they were not."""
    rng = np.random.default_rng(42)
    ns = np.arange(10) * 10_000_000
    msgs, *_ = imu_topic(rng, n=10, stamps=ns, t0=0)
    bag = write_bag(tmp_path / "z", "sqlite3", {"/imu": (IMU, msgs)})
    with pytest.warns(UserWarning, match=r"stamps of '/imu' are not all positive \(1 of 10 zero\)"):
        read_imu(bag)
    msgs, *_ = imu_topic(rng, n=10, stamps=ns, t0=-5)
    msgs = [(1_700_000_000 * 10**9 + int(ns[i]), make) for i, (_, make) in enumerate(msgs)]
    bag = write_bag(tmp_path / "n", "mcap", {"/imu": (IMU, msgs)})
    with pytest.warns(UserWarning, match=r"not all positive \(10 of 10 negative\)"):
        read_imu(bag)


@pytest.mark.parametrize(
    ("kind", "compression"),
    [("ros1", "bz2"), ("ros1", "lz4"), ("mcap", "storage"), ("mcap", "file"), ("sqlite3", "file")],
)
def test_compressed_bag_of_a_quantized_imu_reads_whole(tmp_path, kind, compression):
    """A quantized IMU at rest compresses tenfold: more messages than the stored bytes could hold uncompressed is
    no sign of a damaged index in a compressed bag (was refused: "more than the file can hold"). rosbag2's file
    compression (``ros2 bag record --compression-mode file``) reads too."""
    rng = np.random.default_rng(3)
    n = 3000
    gyr = np.round(rng.normal(0, 0.002, (n, 3)) / 0.001) * 0.001  # a few counts of noise
    acc = np.round((rng.normal(0, 0.01, (n, 3)) + [0, 0, 9.81]) / 0.01) * 0.01
    msgs, t, _, _ = imu_topic(rng, n=n, stamps=np.arange(n, dtype=np.int64) * 10_000_000)
    msgs = [(ns, lambda ts, i=i, m=m: _with_values(m(ts), gyr[i], acc[i])) for i, (ns, m) in enumerate(msgs)]
    bag = write_bag(tmp_path / "q", kind, {"/imu": (IMU, msgs)}, compression=compression)
    size = sum(f.stat().st_size for f in bag.iterdir()) if bag.is_dir() else bag.stat().st_size
    assert n * 64 > size  # the old bound refused this bag
    log = read_imu(bag)
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_array_equal(log.acc, acc)
    np.testing.assert_allclose(log.t, t, rtol=0, atol=1e-9)
    assert sum(c.t.size for c in iter_imu(bag, chunk_rows=1000)) == n


@pytest.mark.parametrize("kind", ["sqlite3", "mcap"])
def test_file_compressed_bag_is_inflated_and_read_by_the_storage_decoders(tmp_path, monkeypatch, kind):
    """``ros2 bag record --compression-mode file``: each .zstd file is inflated into a temporary folder (removed
    after) and read there like a plain bag — not message by message through rosbags (15 µs a message); the
    table names the bag itself. A damaged .zstd file is a one-line error."""
    import tempfile

    import optinav.io.rosbag as rb

    rng = np.random.default_rng(8)
    msgs, t, gyr, acc = imu_topic(rng, n=500)
    bag = write_bag(tmp_path / "fz", kind, {"/imu": (IMU, msgs)}, compression="file")
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))

    def no_rosbags(*a, **k):
        raise AssertionError("read through rosbags' iteration")

    monkeypatch.setattr(rb, "_rosbags_blocks", no_rosbags)
    log = read_imu(bag)
    np.testing.assert_array_equal(log.gyr, gyr)
    np.testing.assert_array_equal(log.acc, acc)
    np.testing.assert_allclose(log.t, t, rtol=0, atol=1e-9)
    assert load_bag(bag).path == bag and len(list(scratch.iterdir())) == 1  # the copy, made once
    rb._TWINS.clear()  # each copy's folder goes with it
    gc.collect()
    assert not any(scratch.iterdir())
    import errno
    import shutil

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(scratch / "x"))

    with monkeypatch.context() as m:
        m.setattr(shutil, "copyfileobj", full)
        with pytest.raises(
            OptinavError, match=r"cannot write a readable copy of fz into a temporary folder \(No space left on device"
        ):
            read_imu(bag)
    assert not any(scratch.iterdir())
    z = next(bag.glob("*.zstd"))
    z.write_bytes(z.read_bytes()[: z.stat().st_size // 2])
    with pytest.raises(OptinavError, match=r"fz is not a readable ROS bag: .*\.zstd is not a complete zstd file"):
        read_imu(bag)
    assert not any(scratch.iterdir())


def test_compressed_bag_whose_index_counts_too_many_is_a_one_line_error(tmp_path):
    """A count beyond the stored bytes in a compressed bag is read as far as the messages go, then refused with
    both numbers (not allocated for, not read as a shorter recording)."""
    rng = np.random.default_rng(4)
    msgs, *_ = imu_topic(rng, n=500)
    bag = write_bag(tmp_path / "f", "sqlite3", {"/imu": (IMU, msgs)}, compression="message")
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace("message_count: 500", "message_count: 1000000000000"))
    with pytest.raises(OptinavError, match=r"holds 500 messages, its index says 1000000000000"):
        read_imu(bag)


def _with_values(msg, gyr, acc):
    for obj, v in ((msg.angular_velocity, gyr), (msg.linear_acceleration, acc)):
        obj.x, obj.y, obj.z = map(float, v)
    return msg


def _first_chunk_cut(path: Path, raw: bytes) -> Path:
    """``path`` holding the ROS 1 bag ``raw`` cut inside its first chunk's connection record: nothing to read."""
    from optinav.io import bagscan

    first = bagscan._record(raw, len(bagscan._ROS1_MAGIC), len(raw))[2]
    path.write_bytes(raw[: first + 100])
    return path


def test_damaged_bags_are_one_line_errors(tmp_path):
    rng = np.random.default_rng(7)
    msgs, *_ = imu_topic(rng, n=200)
    # a ROS 1 or MCAP file cut short gives its complete chunks, or says it holds none (test_bag_recovery)
    for kind in ("ros1", "mcap-file", "sqlite3-file"):
        bag = write_bag(tmp_path / kind, kind, {"/imu": (IMU, msgs)})
        raw = bag.read_bytes()
        cut = tmp_path / f"cut{bag.suffix}"
        cut.write_bytes(raw[: len(raw) // 2])
        with pytest.raises(OptinavError, match=r"not a readable ROS bag"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            read_imu(cut if kind != "ros1" else _first_chunk_cut(cut, raw))
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    with pytest.raises(OptinavError, match="junk.bag is not a readable ROS bag"):
        read_imu(junk)
    (tmp_path / "notabag").mkdir()
    (tmp_path / "notabag" / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 99}\n")
    with pytest.raises(OptinavError, match="not a readable ROS bag"):
        read_imu(tmp_path / "notabag")


def test_a_damaged_topics_table_is_a_one_line_error(tmp_path):
    # found by a fork-per-file fuzz: a damaged sqlite3 bag whose topics table gave a NULL type (here a blob)
    # escaped as an AttributeError (TypeError) while the topics were listed; such a table now goes to rosbags'
    # reader, whose error is one line
    import sqlite3

    rng = np.random.default_rng(3)
    msgs, *_ = imu_topic(rng, n=20)
    bag = write_bag(tmp_path / "b", "sqlite3-file", {"/imu": (IMU, msgs)})
    con = sqlite3.connect(bag)
    con.execute("UPDATE topics SET type = X'00' WHERE name = '/imu'")  # a blob: what damage reads as
    con.commit()
    con.close()
    for read in (lambda: read_imu(bag), lambda: list(iter_imu(bag, chunk_rows=7))):
        with pytest.raises(OptinavError) as exc:
            read()
        assert "\n" not in str(exc.value) and bag.name in str(exc.value)


def test_missing_rosbags_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    bag = tmp_path / "x.bag"
    bag.write_bytes(b"#ROSBAG V2.0\n")
    with pytest.raises(OptinavError, match=r"needs the rosbags library.*pip install 'optinav\[ros\]'"):
        load_bag(bag)


def session_messages(tmp_path):
    """A simulated multi-position session (CSV, its log, its samples as Imu messages stamped from 1.7e9 s)."""
    csv = tmp_path / "s.csv"
    argv = ["--quiet", "simulate", "accel-multipos", "--out", str(csv), "--scheme", "paper12", "--dwell", "4"]
    assert main([*argv, "--seed", "4"]) == 0
    log = read_imu(csv)
    ns = np.round(log.t * 1e9).astype(np.int64) + 1_700_000_000 * 10**9
    msgs = [
        (int(ns[i]), lambda ts, i=i: imu_msg(ts, ns[i] // 10**9, ns[i] % 10**9, log.gyr[i], log.acc[i]))
        for i in range(len(log))
    ]
    return csv, log, msgs


def test_cli_calibrate_and_apply_read_a_bag(tmp_path, capsys):
    """A simulated multi-position session as a ROS 2 bag calibrates like the same samples as CSV."""
    csv, log, msgs = session_messages(tmp_path)
    bag = write_bag(tmp_path / "bag", "sqlite3", {"/imu": (IMU, msgs)})
    out_csv, out_bag = tmp_path / "c.json", tmp_path / "b.json"
    assert main(["--quiet", "calibrate", "accel", str(csv), "--gravity", "9.80", "--out", str(out_csv)]) == 0
    assert (
        main(["--quiet", "calibrate", "accel", str(bag), "--topic", "/imu", "--gravity", "9.80", "--out", str(out_bag)])
        == 0
    )
    from optinav.multipos.result import CalibrationResult

    rc, rb = CalibrationResult.from_json(out_csv), CalibrationResult.from_json(out_bag)
    for sensor in ("accelerometer", "gyroscope"):
        np.testing.assert_allclose(getattr(rb, sensor)["K"], getattr(rc, sensor)["K"], rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(getattr(rb, sensor)["b"], getattr(rc, sensor)["b"], rtol=1e-6, atol=1e-6)
    capsys.readouterr()
    assert main(["apply", str(out_bag), str(bag), "--out", str(tmp_path / "corr.npz")]) == 0
    z = np.load(tmp_path / "corr.npz")
    assert z["acc"].shape == log.acc.shape
    assert main(["calibrate", "accel", str(bag), "--topic", "/gps", "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "optinav: error: bag has no topic '/gps' (topics: /imu (sensor_msgs/Imu, "
        f"{len(log)} msgs)); pass one of the listed topics with --topic"
    ]


def _joined_tables(bag, chunk, **kw):
    from optinav.io.readers import iter_table

    blocks = list(iter_table(bag, chunk_rows=chunk, **kw))
    keys = list(blocks[0].data)
    return blocks, {k: np.concatenate([b.data[k] for b in blocks]) for k in keys}


@pytest.mark.parametrize("kind", KINDS)
def test_bag_read_in_blocks_equals_the_whole_bag(tmp_path, monkeypatch, kind):
    """A bag the scanners read comes in tables of chunk_rows messages (two passes over its storage: the time base,
    then the tables), the MagneticField topic interpolated onto each; joined they are load_bag's columns. The
    storage's own blocks are small here (ROS 1 chunks of 8 KiB, sqlite3 leaves two pages at a time), so that the
    tables cut across them."""
    import optinav.io.bagscan
    from optinav.io import iter_imu
    from optinav.io.readers import load_table

    monkeypatch.setattr(optinav.io.bagscan, "_LEAVES", 2)

    rng = np.random.default_rng(21)
    msgs, t, gyr, acc = imu_topic(rng, n=500)
    tm = np.arange(0, 5.0, 0.04) + 1_700_000_000
    bm = rng.normal(0, 3e-5, (tm.size, 3))
    mags = [
        (int(round(x * 1e9)), lambda ts, k=k: mag_msg(ts, int(tm[k]), round((tm[k] % 1) * 1e9), bm[k]))
        for k, x in enumerate(tm)
    ]
    bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs), "/mag": (MAG, mags)}, chunk_threshold=8192)
    whole = load_table(bag)
    blocks, joined = _joined_tables(bag, 64)
    assert len(blocks) == 8 and [b.row0 for b in blocks] == list(range(0, 500, 64))
    assert list(joined) == list(whole.data) and all(b.meta == whole.meta and b.units == whole.units for b in blocks)
    for k, v in whole.data.items():
        assert np.array_equal(joined[k], v, equal_nan=True), k
    assert np.array_equal(joined["t"], t) and np.array_equal(joined["gx"], gyr[:, 0])
    chunks = iter_imu(bag, chunk_rows=100)
    logs = list(chunks)
    log = read_imu(bag)
    assert len(logs) == 5 and chunks.table is not None and chunks.position == chunks.size
    assert np.array_equal(np.concatenate([x.acc for x in logs]), log.acc)


def test_bag_blocks_keep_the_time_base_and_fall_back_when_out_of_order(tmp_path):
    """Zero header stamps: the log times, decided in the first pass, one warning; log times out of the storage's
    order: the bag is read whole (one table), sorted as load_bag does."""
    rng = np.random.default_rng(22)
    msgs, t, gyr, acc = imu_topic(rng, n=300, stamps=np.zeros(300, np.int64), t0=0)
    logt = 1_700_000_000 * 10**9 + 10_000_000 * np.arange(300)
    bag = write_bag(tmp_path / "z", "ros1", {"/imu": (IMU, [(int(logt[i]), m) for i, (_, m) in enumerate(msgs)])})
    with pytest.warns(UserWarning, match="header stamps of '/imu' are zero") as rec:
        blocks, joined = _joined_tables(bag, 64)
    assert len(blocks) == 5 and len([w for w in rec if "header stamps" in str(w.message)]) == 1
    np.testing.assert_array_equal(joined["t"], logt * 1e-9)
    perm = rng.permutation(300)
    msgs2, *_ = imu_topic(rng, n=300)
    shuffled = [(1_700_000_000 * 10**9 + 1_000_000 * int(perm[i]), make) for i, (_, make) in enumerate(msgs2)]
    bag2 = write_bag(tmp_path / "o", "ros1", {"/imu": (IMU, shuffled)})
    with pytest.warns(UserWarning, match="not strictly increasing"):
        blocks, joined = _joined_tables(bag2, 64)
    assert len(blocks) == 1
    with pytest.warns(UserWarning):
        assert np.array_equal(joined["gx"], read_table(bag2)["gx"])


@settings(max_examples=40)
@given(
    kind=st.sampled_from(("ros1", "mcap-file", "sqlite3-file")),
    where=st.floats(0, 1, exclude_max=True),
    flip=st.integers(1, 255),
)
def test_damaged_bag_in_blocks_gives_the_whole_reading(tmp_path_factory, kind, where, flip):
    """One byte of a bag changed anywhere: its tables of 7 messages join to what the whole reading gives, or both
    end in the same one-line error."""
    suffix, raw = _damage_bags(tmp_path_factory)[kind]
    raw = bytearray(raw)
    raw[int(where * len(raw))] ^= flip
    path = tmp_path_factory.mktemp("d") / f"b{suffix}"
    path.write_bytes(bytes(raw))
    got = []
    for blocks in (True, False):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                got.append(_joined_tables(path, 7)[1] if blocks else dict(read_table(path)))
        except OptinavError as exc:
            assert "\n" not in str(exc)
            got.append(str(exc))
    ours, whole = got
    if isinstance(whole, str) or isinstance(ours, str):
        assert ours == whole
    else:
        assert ours.keys() == whole.keys() and all(np.array_equal(ours[k], whole[k], equal_nan=True) for k in ours)


def _imu_and_mag(rng, n=300, delay_ns=400_000_000, mag_shift_ns=0, dup_mag=None):
    """Imu messages logged ``delay_ns`` after their stamps and a MagneticField topic at a third of the rate
    (stamps shifted by ``mag_shift_ns``; ``dup_mag``: the index of a mag stamp repeated from the one before)."""
    msgs, t, gyr, acc = imu_topic(rng, n=n)
    st = np.round(t * 1e9).astype(np.int64)
    imu = [(int(st[i] + delay_ns), make) for i, (_, make) in enumerate(msgs)]
    ms = st[::3] + mag_shift_ns
    if dup_mag is not None:
        ms[dup_mag] = ms[dup_mag - 1]
    b = rng.normal(0, 2e-5, (ms.size, 3))
    mag = [
        (int(st[3 * k] + delay_ns + 1000), lambda ts, k=k: mag_msg(ts, int(ms[k] // 10**9), int(ms[k] % 10**9), b[k]))
        for k in range(ms.size)
    ]
    return {"/imu": (IMU, imu), "/mag": (MAG, mag)}, st


@pytest.mark.parametrize("chunk", [64, 10_000])
def test_one_topic_on_log_times_puts_both_there(tmp_path, chunk):
    """One repeated MagneticField stamp moved the magnetometer to the bag's log times while the Imu stayed on its
    header stamps: 0.4 s apart, the yaw off by up to 19° with exit 0. One clock for both now."""
    rng = np.random.default_rng(31)
    topics, st = _imu_and_mag(rng, dup_mag=10)
    bag = write_bag(tmp_path / "b", "sqlite3", topics)
    with pytest.warns(UserWarning, match="one clock for both topics"):
        _, joined = _joined_tables(bag, chunk)
    np.testing.assert_allclose(joined["t"], (st + 400_000_000) * 1e-9, rtol=0, atol=1e-9)
    clean = write_bag(tmp_path / "c", "sqlite3", _imu_and_mag(np.random.default_rng(31))[0])
    _, ref = _joined_tables(clean, chunk)
    # the same values on one clock (the mag logged 1 µs after its Imu message: 1e-4 of them)
    np.testing.assert_allclose(joined["mx"][1:-1], ref["mx"][1:-1], rtol=0, atol=1e-8)


def test_a_write_ahead_log_beside_a_db3_is_folded_into_a_copy(tmp_path):
    """A recording in WAL mode (``--storage-preset-profile resilient``) copied while running or left by a crash:
    half its messages were only in X.db3-wal, which neither the scanners nor rosbags read — 10 000 of 20 000
    messages with exit 0; then it was refused, the remedy needing the sqlite3 program. Now read from a copy that
    SQLite itself folded the log into, with a warning; the input files are left as they were."""
    import shutil
    import sqlite3

    msgs, t, gyr, _ = imu_topic(np.random.default_rng(32), n=100)
    db3 = write_bag(tmp_path / "w", "sqlite3-file", {"/imu": (IMU, msgs)})
    con = sqlite3.connect(db3)
    rows = con.execute("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id").fetchall()
    con.execute("DELETE FROM messages WHERE id > ?", (rows[49][0],))
    con.commit()
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("PRAGMA wal_autocheckpoint=0")
    con.executemany("INSERT INTO messages VALUES (?, ?, ?, ?)", rows[50:])
    con.commit()
    crash = tmp_path / "crash"
    crash.mkdir()
    for f in (db3, db3.with_name(db3.name + "-wal")):  # copied while the recorder holds it open
        shutil.copyfile(f, crash / f.name)
    con.close()
    left = crash / db3.name
    before = {f.name: f.read_bytes() for f in crash.iterdir()}
    with pytest.warns(UserWarning, match=r"w\.db3 has a write-ahead log \(w\.db3-wal: \d+ bytes\) with messages not"):
        log = read_imu(left)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr)
    assert np.array_equal(_joined_tables(left, 16)[1]["gx"], gyr[:, 0])  # the same copy, said once
    assert {f.name: f.read_bytes() for f in crash.iterdir()} == before
    assert len(read_imu(db3)) == 100  # closed: the log folded in by SQLite at close
    (crash / "w.db3-wal").write_bytes(b"\x37\x7f\x06\x82" + bytes(60))  # no valid frame: SQLite ignores it
    with pytest.warns(UserWarning, match="write-ahead log"):
        assert len(read_imu(left)) == 50


def test_a_mag_topic_named_without_mag_is_refused(tmp_path, capsys):
    """``attitude BAG --topic /imu,/mag`` without --mag wrote the gyro-only attitude with exit 0, the MagneticField
    topic named and left out. Now refused naming --mag; with it the magnetometer is used, as with --mag alone."""
    topics, _ = _imu_and_mag(np.random.default_rng(1), n=600)
    bag = write_bag(tmp_path / "m", "sqlite3", topics)
    out = tmp_path / "o.csv"
    assert main(["--quiet", "attitude", str(bag), "--topic", "/imu,/mag", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "optinav: error: --topic names the magnetometer topic /mag of m, and --mag was not given: the estimate would "
        "leave it out; add --mag (9D), or drop /mag from --topic (6D)"
    ], err
    assert not out.exists()
    assert main(["--quiet", "attitude", str(bag), "--topic", "/imu,/mag", "--mag", "--out", str(out)]) == 0
    both = out.read_bytes()
    assert main(["--quiet", "attitude", str(bag), "--mag", "--out", str(out)]) == 0
    assert out.read_bytes() == both
    assert main(["--quiet", "attitude", str(bag), "--topic", "/imu", "--out", str(out)]) == 0


def test_mag_topic_on_another_clock_and_missing(tmp_path, capsys):
    """A MagneticField topic stamped 150 s off the Imu's gave 'magnetometer used 0 %' and a gyro-only heading with
    exit 0 under --mag: a warning from the reader, and attitude --mag refuses a magnetometer without a
    finite sample (a CSV of NaN mag columns too); without --mag the bag runs. A bag without any MagneticField
    topic named a missing array 'mx'; a folder of .db3 files without metadata.yaml was 'a folder'."""
    rng = np.random.default_rng(33)
    topics, _ = _imu_and_mag(rng, n=600, delay_ns=1000, mag_shift_ns=-150 * 10**9)
    bag = write_bag(tmp_path / "m", "sqlite3", topics)
    out = str(tmp_path / "o.csv")
    assert main(["--quiet", "attitude", str(bag), "--mag", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "never meet those of '/imu'" in err and "no sample with three finite values" in err, err
    assert main(["--quiet", "attitude", str(bag), "--out", out]) == 0
    capsys.readouterr()
    imu_only = write_bag(tmp_path / "i", "sqlite3", {"/imu": topics["/imu"]})
    assert main(["--quiet", "attitude", str(imu_only), "--mag", "--out", out]) == 2
    assert "has no MagneticField topic" in capsys.readouterr().err
    rec = tmp_path / "rec"
    rec.mkdir()
    for f in imu_only.glob("*.db3"):
        (rec / f.name).write_bytes(f.read_bytes())
    assert main(["attitude", str(rec), "--out", out]) == 0  # its one file (test_bag_recovery)
    assert "rec has no metadata.yaml (its recording did not close): read from its one file" in capsys.readouterr().err


def test_batch_takes_ros2_bag_folders_and_bag_files(tmp_path, capsys):
    """A folder of recordings as `ros2 bag record` leaves them (each a folder holding metadata.yaml) beside a
    ROS 1 bag and a CSV of the same samples: the bag folders were skipped without a word ("1 units"), a folder
    of only them "holds no data files". Each is now a unit named after its folder, with the values of the
    others, and a re-run resumes it."""
    from optinav.batch import read_results

    rng = np.random.default_rng(4)
    n, t0 = 3000, 1_700_000_000
    ns = np.arange(n, dtype=np.int64) * 10_000_000
    gyr = rng.normal(0, 0.01, (n, 3))
    acc = rng.normal(0, 0.05, (n, 3)) + [0, 0, 9.81]
    msgs = [
        (t0 * 10**9 + int(ns[i]), lambda ts, i=i: imu_msg(ts, t0 + ns[i] // 10**9, ns[i] % 10**9, gyr[i], acc[i]))
        for i in range(n)
    ]
    units = tmp_path / "units"
    units.mkdir()
    write_bag(units / "b_ros2", "mcap", {"/imu": (IMU, msgs)})
    write_bag(units / "c_ros1", "ros1", {"/imu": (IMU, msgs)})
    np.savetxt(
        units / "a.csv",
        np.column_stack([t0 + ns * 1e-9, acc, gyr]),
        delimiter=",",
        header="t,ax,ay,az,gx,gy,gz",
        comments="",
    )
    out = tmp_path / "res.csv"
    argv = ["--quiet", "batch", "attitude", str(units), "--frame", "ENU", "--out", str(out), "--workers", "0"]
    assert main(argv) == 0
    rows = {r["unit"]: r for r in read_results(out)}
    assert sorted(rows) == ["a", "b_ros2", "c_ros1"]
    assert all(r["status"] == "ok" and r["n_samples"] == n for r in rows.values())
    bias = {u: np.array([rows[u][f"gyr_bias_{a}"] for a in "xyz"]) for u in rows}
    np.testing.assert_allclose(bias["b_ros2"], bias["a"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(bias["c_ros1"], bias["a"], rtol=0, atol=1e-9)
    capsys.readouterr()
    assert main(argv) == 0
    assert "(3 resumed from the journal, 0 computed now)" in capsys.readouterr().out
    for p in units.iterdir():
        if p.name != "b_ros2":
            p.unlink()
    out2 = tmp_path / "res2.csv"
    assert main(argv[:4] + ["--frame", "ENU", "--out", str(out2), "--workers", "0"]) == 0
    assert [r["unit"] for r in read_results(out2)] == ["b_ros2"]


@pytest.mark.parametrize("kind", ("ros1", "mcap"))
def test_an_empty_second_imu_topic_leaves_the_one_that_published(tmp_path, kind):
    """Two Imu topics, one advertised but never published (a second driver started without its sensor): the bag
    was refused with "pick one with --topic", though only one can be read. That one is read now, with a warning
    naming the empty one; named, the empty one is refused."""
    rng = np.random.default_rng(53)
    msgs, t, gyr, _ = imu_topic(rng, n=60)
    bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs), "/imu_raw": (IMU, [])})
    with pytest.warns(UserWarning, match="'/imu' read; '/imu_raw' hold"):
        log = read_imu(bag)
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr)
    with pytest.raises(OptinavError, match="'/imu_raw' of b.* holds no messages"):
        read_imu(bag, topic="/imu_raw")


@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_three_imus_on_one_topic_keep_their_frame_ids_across_blocks(tmp_path, kind):
    """Three frame_ids interleaved: a storage block (a ROS 1 chunk of 4 KiB here) may start with any of them, and
    the decoder's list of frame_ids was reset at every block (to the block's first message's), so a row coded in
    an earlier block named another frame_id later — --topic /imu@B read other IMUs' rows with exit 0. Each
    selection reads its own IMU's values."""
    rng = np.random.default_rng(49)
    n = 2000
    names = ("imuA", "imuB", "imuC")
    parts = []
    for k, name in enumerate(names):
        stamps = np.round(np.arange(n) / 100 * 1e9).astype(np.int64) + 1_000_000 * (k + 1) + 123
        parts.append(imu_topic(rng, n=n, frames=(name,), stamps=stamps))
    msgs = sorted((m for p in parts for m in p[0]), key=lambda m: m[0])
    bag = write_bag(tmp_path / "b", kind, {"/imu": (IMU, msgs)}, chunk_threshold=4096 if kind == "ros1" else None)
    for k, name in enumerate(names):
        log = read_imu(bag, topic=f"/imu@{name}")
        assert np.array_equal(log.t, parts[k][1]) and np.array_equal(log.gyr, parts[k][2]), name


@pytest.mark.parametrize("kind", ("sqlite3", "mcap"))
def test_two_imus_on_one_topic_under_one_frame_id_are_refused(tmp_path, kind, capsys):
    """Two IMU drivers publishing /imu with the same frame_id (a copied launch file): rosbag2 keeps no publisher per
    message, so the messages of both — 100 Hz each, stamps 3 ms apart — were read as one IMU at 200 Hz with exit 0,
    its samples alternating between two sensors. Their bias difference (0.05 m/s², 0.003 rad/s, noise 0.02 m/s²,
    0.002 rad/s) alternates: refused, naming what helps, whole and in blocks. Each IMU alone (a slow rotation, a
    straight drift) still reads."""
    rng = np.random.default_rng(47)
    n, t0 = 600, 1_700_000_000
    ts = np.arange(n) / 100.0
    motion = np.column_stack([0.3 * np.sin(2 * np.pi * 0.2 * ts), 0.01 * ts, np.zeros(n)])

    def sensor(bias_a, bias_g, offset_ns):
        acc = [0, 0, 9.81] + bias_a + rng.normal(0, 0.02, (n, 3))
        gyr = motion + bias_g + rng.normal(0, 0.002, (n, 3))
        ns = np.round(ts * 1e9).astype(np.int64) + offset_ns
        msgs = [
            (
                int(t0 * 10**9 + ns[i] + 5_000_000),
                lambda s, i=i: imu_msg(s, t0 + ns[i] // 10**9, ns[i] % 10**9, gyr[i], acc[i]),
            )
            for i in range(n)
        ]
        return msgs, gyr

    a, gyr_a = sensor(np.array([0.05, -0.03, 0.0]), np.array([0.003, 0.0, 0.0]), 123)
    b, _ = sensor(np.zeros(3), np.zeros(3), 3_000_123)
    both = write_bag(tmp_path / "both", kind, {"/imu": (IMU, sorted(a + b, key=lambda m: m[0]))})
    with pytest.raises(OptinavError, match="alternate between two sensors.*own topic or frame_id"):
        read_imu(both)
    assert main(["attitude", str(both), "--chunk-rows", "500", "--out", str(tmp_path / "q.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "alternate between two sensors" in err[0], err
    one = write_bag(tmp_path / "one", kind, {"/imu": (IMU, a)})
    assert np.array_equal(read_imu(one).gyr, gyr_a)


def test_alternation_of_one_real_imu_stays_far_below_the_refusal():
    """The two-sensor check on real data: BROAD's nine trials (one IMU each: rotations, translations, tapping,
    vibration) stay below half the threshold; each interleaved with itself offset by a small bias difference on
    every axis (0.05, -0.03, 0.04 m/s²; 0.003 rad/s: two units of one type) goes beyond it."""
    from optinav.attitude.data import load_broad
    from optinav.io.imu import _ALTERNATE_Z, alternation

    broad = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "attitude" / "broad"
    trials = sorted(p for p in broad.glob("*") if p.suffix in (".hdf5", ".mat"))
    if not trials:
        pytest.skip("BROAD data absent")
    for path in trials:
        tr = load_broad(path)
        z = []
        for x, bias in ((tr.acc, [0.05, -0.03, 0.04]), (tr.gyr, 0.003)):
            assert alternation(x)[0].max() < _ALTERNATE_Z / 2, path.name
            mixed = x.copy()
            mixed[1::2] += bias
            z.append(alternation(mixed)[0].max())
        assert max(z) > _ALTERNATE_Z, path.name


def test_alternation_of_a_triad_is_the_general_sums_to_the_bit():
    """The two-sensor check's sums of an (N, 3) triad (a pass of its own, in scalars) are those of the general
    pass over the same columns beside a fourth of zeros, bit for bit, with NaN and inf rows left out alike; and
    the check of a long log's two triads (the gyro's in the helper thread) names the triad that alternates."""
    from types import SimpleNamespace

    from optinav.io._bagkernels import alternation_sums
    from optinav.io.imu import _COMPILED_ROWS, _one_source

    rng = np.random.default_rng(53)
    for n in (2, 3, 1001, 20_000):
        x = rng.normal(0, 0.02, (n, 3)) + [0.1, -0.2, 9.81]
        x[rng.random((n, 3)) < 0.01] = np.nan
        if n > 10:
            x[7, 1] = np.inf
        m3, v3, m4, v4 = np.zeros(3), np.zeros(3), np.zeros(4), np.zeros(4)
        c3 = alternation_sums(x, m3, v3)
        c4 = alternation_sums(np.column_stack([x, np.zeros(n)]), m4, v4)
        assert c3 == c4 and np.array_equal(m3, m4[:3]) and np.array_equal(v3, v4[:3]), n
    n = _COMPILED_ROWS + 1001
    acc = rng.normal(0, 0.02, (n, 3)) + [0, 0, 9.81]
    gyr = rng.normal(0, 0.002, (n, 3))
    table = SimpleNamespace(meta={"topic": "/imu"})
    _one_source(SimpleNamespace(acc=acc, gyro=gyr, path=Path("b.bag")), table)  # one IMU: read
    for kind in ("acc", "gyro"):
        mixed = {"acc": acc.copy(), "gyro": gyr.copy()}
        mixed[kind][1::2, 1] += 0.05 if kind == "acc" else 0.003
        with pytest.raises(OptinavError, match=f"every other {kind} y departs"):
            _one_source(SimpleNamespace(path=Path("b.bag"), **mixed), table)


def test_a_long_triad_gives_its_range_in_the_two_sensor_pass(tmp_path, monkeypatch):
    """Each triad of a long bag topic gives the value check its range in the pass of the two-sensor sums (a pass
    of its own before: 11 of 25 ms for 3.6 M messages, both triads at once): numpy's min and max to the bit, NaN
    where a value is NaN, an inf kept; the sums those of the general pass. A value beyond MAX_VALUE and two
    sensors in alternate messages are still refused, NaN cells counted."""
    from optinav.io import _bagkernels as kern
    from optinav.io import imu

    rng = np.random.default_rng(61)
    for n in (1, 2, 3, 4, 7, 1000, 1001):
        for fault in (None, np.nan, np.inf, -np.inf):
            x = rng.normal(0, 1, (n, 3)) + [0.1, -0.2, 9.81]
            if fault is not None:
                x[rng.integers(n), rng.integers(3)] = fault
            bounds, m, v, m0, v0 = np.empty(2), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
            assert kern.alternation_range(x, m, v, bounds) == kern.alternation_sums(x, m0, v0)
            assert np.array_equal(m, m0) and np.array_equal(v, v0)
            np.testing.assert_array_equal(bounds, [x.min(), x.max()])
    monkeypatch.setattr(imu, "_COMPILED_ROWS", 1000)  # the compiled passes for a short topic
    ranges = []
    own_range = imu._range
    monkeypatch.setattr(imu, "_range", lambda tri: ranges.append(tri.shape) or own_range(tri))
    msgs, t, gyr, acc = imu_topic(rng, n=3001, rate=1000.0)
    acc[5, 1] = gyr[9, 2] = np.nan
    log = read_imu(write_bag(tmp_path / "b", "ros1", {"/imu": (IMU, msgs)}))
    assert not ranges and log.nan_rows == 2
    assert np.array_equal(log.acc, acc, equal_nan=True) and np.array_equal(log.gyr, gyr, equal_nan=True)
    acc[7, 2] = 2e12
    with pytest.raises(OptinavError, match=r"the acc column 'az' holds 2e\+12 in data row 8"):
        read_imu(write_bag(tmp_path / "huge", "ros1", {"/imu": (IMU, msgs)}))
    acc[7, 2] = 9.81
    gyr[1::2, 0] += 0.3
    with pytest.raises(OptinavError, match="every other gyro x departs"):
        read_imu(write_bag(tmp_path / "two", "ros1", {"/imu": (IMU, msgs)}))


def test_a_batch_that_raises_stops_the_other_thread(tmp_path, monkeypatch):
    """An error in one thread's batch (here the first batch of the helper) stops the other thread at its next
    batch, instead of it decoding the rest of the bag before the error is seen; the error reaches the reader,
    which then reads the topic another way (the values written)."""
    from optinav.io import _bagkernels as kern
    from optinav.io import bagscan

    rng = np.random.default_rng(59)
    msgs, t, gyr, acc = imu_topic(rng, n=3001, rate=1000.0)
    bag = write_bag(tmp_path / "b", "ros1", {"/imu": (IMU, msgs)}, chunk_threshold=16384)
    monkeypatch.setattr(bagscan, "_ROUND", 20_000)
    monkeypatch.setattr(bagscan, "_helper", lambda: _SpyPool())
    import threading
    import time

    real, me, calls = kern.ros1_decode, threading.get_ident(), []

    def failing(*args):
        calls.append(threading.get_ident() == me)
        if threading.get_ident() != me:
            raise ValueError("a damaged chunk")
        time.sleep(0.005)
        return real(*args)

    monkeypatch.setattr(kern, "ros1_decode", failing)
    decoded = _spy_decode(monkeypatch, "ros1_decode")
    log = read_imu(bag)
    assert decoded == [] and calls.count(False) == 1 and calls.count(True) <= 2  # of about 40 batches
    assert np.array_equal(log.t, t) and np.array_equal(log.gyr, gyr) and np.array_equal(log.acc, acc)


class _LatePool:
    """A stand-in for the helper thread whose CPU is busy with other work: each job starts 0.2 s after it is
    handed over, unless it was cancelled before; counts the jobs that ran."""

    def __init__(self):
        self.ran = 0

    def submit(self, fn, *args):
        import threading
        from concurrent.futures import Future

        fut = Future()

        def start():
            if fut.set_running_or_notify_cancel():
                self.ran += 1
                try:
                    fut.set_result(fn(*args))
                except BaseException as exc:  # noqa: BLE001 - handed to the waiting reader
                    fut.set_exception(exc)

        threading.Timer(0.2, start).start()
        return fut


def test_sqlite_batches_not_started_by_the_helper_are_decoded_here(tmp_path, monkeypatch):
    """sqlite3 batches that the helper thread has not started taking when this thread is done with them all (its
    CPU busy with another process) are decoded by this thread, the helper not waited for: it runs no batch, and
    the values are those of one thread (Imu and MagneticField interleaved, odd counts)."""

    from optinav.io import bagscan

    rng = np.random.default_rng(61)
    msgs, t, gyr, acc = imu_topic(rng, n=1201, rate=1000.0)
    mags = [(1_700_000_000 * 10**9 + 10**7 * k + 3, lambda ts, k=k: mag_msg(ts, 1_700_000_000, 10**7 * k, rng.normal(0, 1e-5, 3))) for k in range(121)]  # fmt: skip
    bag = _imu_mag_sqlite_in_small_rounds(tmp_path, monkeypatch, msgs, mags, 8)
    one = read_table(bag)
    late = _LatePool()
    monkeypatch.setattr(bagscan, "_helper", lambda: late)
    calls = _spy_decode(monkeypatch, "sqlite_decode")
    two = read_table(bag)
    assert calls == [1201, 121] and late.ran == 0
    for k in one:
        assert np.array_equal(two[k], one[k], equal_nan=True), k
    assert np.array_equal(two["t"], t) and np.array_equal(two["gx"], gyr[:, 0])
