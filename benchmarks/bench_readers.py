"""Reading a 1-hour 1 kHz IMU log (3.6 M samples) from Parquet and from ROS bags: time and peak memory.

The same samples (time, accelerometer, gyroscope; float64) are written as a Parquet file (pyarrow, snappy,
default row groups) and as ROS bags of ``sensor_msgs/msg/Imu`` messages: ROS 2 sqlite3, ROS 2 mcap (also with
chunk CRCs) and ROS 1 (rosbags' writers; the message bytes are rosbags' serialization of one message with the stamp and values
patched in, which keeps writing 3.6 M messages to minutes). Each reading runs in a fresh process: the time
of the read (best of ``REPEAT`` for Parquet and optinav's reading of bags, one read for rosbags and for a fresh
process's first read) and the growth of the peak resident set over
the resident set after the imports (``VmHWM`` and ``VmRSS`` of ``/proc/self/status``, Linux; not
``getrusage``, whose peak survives the exec and so includes the parent's; the peak is reset after the imports
through ``/proc/self/clear_refs``; pyarrow allocates outside Python, so tracemalloc would miss it).

Methods side by side: ``pyarrow.parquet.read_table`` of the file (the reference: an Arrow table, no conversion);
``optinav read_imu`` of the Parquet file and of each bag (an :class:`optinav.io.ImuLog` with every check; the
bag scanners' and the column interleave's numba kernels loaded and rosbags' type stores imported before the
timing, like the other imports),
and of each bag once more, the first read of a process with only ``optinav.io`` imported before the timing
(rosbags' imports, numba's import and start — about 1.5 s, which any optinav pipeline using numba pays once — and
the first allocations from the OS inside it);
for each bag rosbags' own iteration over the raw messages (``AnyReader.messages``, no decoding: what reading
through rosbags costs at least), and for the sqlite3 bag rosbags' per-message deserializer
(``AnyReader.deserialize``), the usual way to read a bag in Python. Target (issue 14): the reader no slower than
2x pyarrow. ``OPTINAV_BENCH_BEFORE=SRC`` adds the reading of each bag by the optinav whose source is in SRC,
in the same run (before/after a change). Quick: 100 000 samples. ``python benchmarks/bench_readers.py RESULTS.json`` prints the Markdown
table of a results file (results_readers.md).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

RATE = 1000.0
REPEAT = 5  # best of: the machine is shared, and a read now and then lands on a busy spell
#: the ``src`` folder of an earlier optinav, whose read_imu of each bag is timed beside this one's in the same run
BEFORE = os.environ.get("OPTINAV_BENCH_BEFORE")

_CHILD = r"""
import json, sys, time
import numpy as np
kind, path, repeat = sys.argv[1], sys.argv[2], int(sys.argv[3])
if kind == "pyarrow":
    import pyarrow.parquet as pq
    def read():
        return pq.read_table(path).num_rows
elif kind == "rosbags-raw":
    from pathlib import Path
    from rosbags.highlevel import AnyReader
    def read():
        n = 0
        with AnyReader([Path(path)]) as r:
            for _ in r.messages():
                n += 1
        return n
elif kind == "rosbags":
    from pathlib import Path
    from rosbags.highlevel import AnyReader
    def read():
        with AnyReader([Path(path)]) as r:
            acc = np.empty((r.connections[0].msgcount, 3))
            for i, (con, _, raw) in enumerate(r.messages()):
                m = r.deserialize(raw, con.msgtype)
                a = m.linear_acceleration
                acc[i] = (a.x, a.y, a.z)
        return acc.shape[0]
elif kind == "optinav-cold":
    from optinav.io import read_imu  # the rest (pyarrow or rosbags, numba and its kernels) inside the timing
    def read():
        return len(read_imu(path))
else:
    from optinav.io import read_imu
    import optinav.io.parquet, optinav.io.rosbag  # noqa: F401 - imports outside the timing
    import pyarrow.parquet, rosbags.highlevel  # noqa: F401
    import rosbags.typesys.stores.latest, rosbags.typesys.stores.ros1_noetic  # noqa: F401 - the type stores
    if path.endswith(".parquet"):
        from optinav.io import _colkernels  # numba's start and the interleave's cached code, as for the bags
        _colkernels.interleave3(*np.zeros((3, 1)), np.zeros((1, 3)))
    else:
        try:
            from optinav.io import _bagkernels
        except ImportError:  # an optinav before the compiled scanners (OPTINAV_BENCH_BEFORE)
            _bagkernels = None
        if _bagkernels is not None:
            _bagkernels.warm()  # numba's start and the kernels' cached code, outside the timing like the imports
    def read():
        return len(read_imu(path))
def status_kib(key):
    with open("/proc/self/status") as fh:
        return next(int(x.split()[1]) for x in fh if x.startswith(key + ":"))
import gc; gc.collect()
with open("/proc/self/clear_refs", "w") as fh:  # reset VmHWM: the imports' peak is not the read's
    fh.write("5")
base = status_kib("VmRSS")
best = float("inf")
for _ in range(repeat):
    t0 = time.perf_counter()
    n = read()
    best = min(best, time.perf_counter() - t0)
peak = status_kib("VmHWM")  # not ru_maxrss: it keeps the peak of the forking parent across exec
print(json.dumps({"n": n, "seconds": best, "peak_growth_mib": (peak - base) / 1024.0}))
"""


def _child(kind: str, path: Path, repeat: int, src: str | None = None) -> dict:
    env = None if src is None else {**os.environ, "PYTHONPATH": src}
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, kind, str(path), str(repeat)], capture_output=True, text=True, env=env
    )
    if proc.returncode != 0:
        raise RuntimeError(f"{kind} {path.name} failed: {proc.stderr.strip()[-400:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _samples(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    ns = 1_700_000_000 * 10**9 + np.round(np.arange(n) * (1e9 / RATE)).astype(np.int64)
    acc = rng.normal(0, 0.02, (n, 3)) + [0.0, 0.0, 9.81]
    gyr = rng.normal(0, 1e-3, (n, 3))
    return ns, acc, gyr


def _write_parquet(path: Path, ns, acc, gyr) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = (ns // 10**9) + (ns % 10**9) * 1e-9
    cols = {
        "t": t,
        **{f"a{a}": acc[:, j] for j, a in enumerate("xyz")},
        **{f"g{a}": gyr[:, j] for j, a in enumerate("xyz")},
    }
    pq.write_table(pa.table(cols), path)


def _messages(kind: str, ns, acc, gyr):
    """The serialized messages as one (n, L) byte array: rosbags' bytes of one message, stamps and values
    patched in at the offsets found by serializing a second message with other values."""
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    T = ts.types
    H = T["std_msgs/msg/Header"]

    def ser(sec, nsec, g, a):
        stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)
        hdr = H(seq=0, stamp=stamp, frame_id="imu_link") if kind == "ros1" else H(stamp=stamp, frame_id="imu_link")
        V, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
        msg = T["sensor_msgs/msg/Imu"](
            header=hdr,
            orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.zeros(9),
            angular_velocity=V(*g),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=V(*a),
            linear_acceleration_covariance=np.zeros(9),
        )
        raw = (
            ts.serialize_ros1(msg, "sensor_msgs/msg/Imu")
            if kind == "ros1"
            else ts.serialize_cdr(msg, "sensor_msgs/msg/Imu")
        )
        return np.frombuffer(bytes(raw), np.uint8)

    base = ser(0x01020304, 0x05060708, (1.5, 2.5, 3.5), (4.5, 5.5, 6.5))

    def where(value, fmt):
        pat = np.frombuffer(np.asarray(value, fmt).tobytes(), np.uint8)
        hits = [i for i in range(base.size - pat.size + 1) if np.array_equal(base[i : i + pat.size], pat)]
        assert len(hits) == 1, (value, hits)
        return hits[0]

    out = np.tile(base, (len(ns), 1))
    for value, fmt, col in ((0x01020304, "<u4", ns // 10**9), (0x05060708, "<u4", ns % 10**9)):
        out[:, where(value, fmt) : where(value, fmt) + 4] = col.astype("<u4").view(np.uint8).reshape(-1, 4)
    for j, v in enumerate((1.5, 2.5, 3.5)):
        k = where(v, "<f8")
        out[:, k : k + 8] = np.ascontiguousarray(gyr[:, j]).astype("<f8").view(np.uint8).reshape(-1, 8)
    for j, v in enumerate((4.5, 5.5, 6.5)):
        k = where(v, "<f8")
        out[:, k : k + 8] = np.ascontiguousarray(acc[:, j]).astype("<f8").view(np.uint8).reshape(-1, 8)
    return out


def _write_bag(path: Path, kind: str, ns, acc, gyr, compression: str | None = None) -> Path:
    """``compression``: ROS 1 chunks ``"lz4"``/``"bz2"``, ROS 2 ``"zstd"`` (storage: compressed chunks),
    ``"file-zstd"`` (each storage file compressed whole: ``ros2 bag record --compression-mode file``) or
    ``"message-zstd"`` (each message compressed: ``--compression-mode message``)."""
    msgs = _messages(kind, ns, acc, gyr)
    if kind == "ros1":
        from rosbags.rosbag1 import Writer
        from rosbags.typesys import Stores, get_typestore

        path = path.with_suffix(".bag")
        w = Writer(path)
        if compression:
            w.set_compression(Writer.CompressionFormat[compression.upper()])
        with w:
            con = w.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=get_typestore(Stores.ROS1_NOETIC))
            for t, m in zip(ns.tolist(), msgs):
                w.write(con, t, m.tobytes())
        return path
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    w = Writer(path, version=9, storage_plugin=plugin)
    if compression:
        mode, _, fmt = compression.rpartition("-")
        w.set_compression(CompressionMode[(mode or "storage").upper()], CompressionFormat[fmt.upper()])
    with w:
        con = w.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=get_typestore(Stores.ROS2_HUMBLE))
        for t, m in zip(ns.tolist(), msgs):
            w.write(con, t, m.tobytes())
    return path


def _with_chunk_crcs(bag: Path, out: Path) -> Path:
    """A copy of the ROS 2 mcap bag folder ``bag`` whose uncompressed Chunk records carry their CRC-32 (what the
    mcap library and ``ros2 bag record`` write; rosbags' writer writes 0, none): the cost of checking them."""
    import shutil
    import struct
    import zlib

    shutil.copytree(bag, out)
    mcap = next(out.glob("*.mcap"))
    raw = bytearray(mcap.read_bytes())
    pos = 8
    while pos + 9 <= len(raw) and raw[pos] not in (0x0F, 0x02):  # records up to Data End / Footer
        n = struct.unpack_from("<Q", raw, pos + 1)[0]
        if raw[pos] == 0x06:  # Chunk: start, end, uncompressed size u64, CRC u32, compression (len u32 + str), ...
            s = pos + 9
            if struct.unpack_from("<I", raw, s + 28)[0] != 0:
                raise RuntimeError("a compressed chunk: expected none")
            rlen = struct.unpack_from("<Q", raw, s + 32)[0]
            struct.pack_into("<I", raw, s + 24, zlib.crc32(raw[s + 40 : s + 40 + rlen]))
        pos += 9 + n
    mcap.write_bytes(bytes(raw))
    return out


def _check(path: Path, ns, acc, gyr) -> None:
    """The reader returns the samples written (else the timing is meaningless)."""
    from optinav.io import read_imu

    log = read_imu(path)
    t = (ns // 10**9) + (ns % 10**9) * 1e-9
    if not (np.array_equal(log.t, t) and np.array_equal(log.acc, acc) and np.array_equal(log.gyr, gyr)):
        raise RuntimeError(f"{path.name}: the values read differ from those written")


def run(quick: bool) -> list[dict]:
    n = 100_000 if quick else int(3600 * RATE)
    ns, acc, gyr = _samples(n)
    group = f"read {n} IMU samples ({n / RATE / 3600:.3g} h at 1 kHz)"
    rows = []

    def add(method, res, fmt):
        rows.append({"group": group, "method": method, "metric": f"{fmt}: time", "value": res["seconds"], "unit": "s"})
        rows.append(
            {
                "group": group,
                "method": method,
                "metric": f"{fmt}: peak memory growth",
                "value": res["peak_growth_mib"],
                "unit": "MiB",
            }
        )

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        pqf = d / "imu.parquet"
        _write_parquet(pqf, ns, acc, gyr)
        _check(pqf, ns, acc, gyr)
        ref = _child("pyarrow", pqf, REPEAT)
        add("pyarrow.parquet.read_table", ref, "Parquet")
        ours = _child("optinav", pqf, REPEAT)
        add("optinav read_imu", ours, "Parquet")
        rows.append(
            {
                "group": group,
                "method": "optinav read_imu",
                "metric": "Parquet: time / pyarrow time",
                "value": ours["seconds"] / ref["seconds"],
                "unit": "x (target <= 2)",
            }
        )
        kinds = (("sqlite3", "ROS 2 sqlite3 bag"), ("mcap", "ROS 2 mcap bag"),
                 ("mcap-crc", "ROS 2 mcap bag, chunk CRCs (as ros2 bag record writes)"), ("ros1", "ROS 1 bag"))  # fmt: skip
        bags: dict = {}
        for kind, label in kinds:
            if kind == "mcap-crc":
                bag = _with_chunk_crcs(bags["mcap"], d / "imu_mcap_crc")
            else:
                bag = bags[kind] = _write_bag(d / f"imu_{kind}", kind, ns, acc, gyr)
            _check(bag, ns, acc, gyr)
            if os.environ.get("OPTINAV_BENCH_BEFORE"):  # another optinav's source tree, read in the same run
                add("optinav read_imu, before (OPTINAV_BENCH_BEFORE)", _child("optinav", bag, REPEAT, BEFORE), label)
            res = _child("optinav", bag, REPEAT)
            add("optinav read_imu", res, label)
            rows.append(
                {
                    "group": group,
                    "method": "optinav read_imu",
                    "metric": f"{label}: time / pyarrow time (Parquet of the same samples)",
                    "value": res["seconds"] / ref["seconds"],
                    "unit": "x",
                }
            )
            if kind == "mcap-crc":
                continue
            cold = _child("optinav-cold", bag, 1)
            add("optinav read_imu, fresh process (imports and numba's start timed)", cold, label)
            add("rosbags raw iteration (no decoding)", _child("rosbags-raw", bag, 1), label)
            if kind == "sqlite3":
                add("rosbags deserialize per message", _child("rosbags", bag, 1), label)
        # bags as loggers often write them: compressed chunks (1 M messages; the codecs dominate)
        nc = 20_000 if quick else 1_000_000
        ns, acc, gyr = _samples(nc)
        group = f"read {nc} IMU samples from compressed chunks"
        for kind, comp, label in (("ros1", "lz4", "ROS 1 bag, lz4"), ("ros1", "bz2", "ROS 1 bag, bz2"),
                                  ("mcap", "zstd", "ROS 2 mcap bag, zstd"),
                                  ("mcap", "file-zstd", "ROS 2 mcap bag, file-compressed (zstd)"),
                                  ("sqlite3", "file-zstd", "ROS 2 sqlite3 bag, file-compressed (zstd)"),
                                  ("mcap", "message-zstd", "ROS 2 mcap bag, message-compressed (zstd)"),
                                  ("sqlite3", "message-zstd", "ROS 2 sqlite3 bag, message-compressed (zstd)")):  # fmt: skip
            bag = _write_bag(d / f"imu_{kind}_{comp}", kind, ns, acc, gyr, comp)
            _check(bag, ns, acc, gyr)
            if os.environ.get("OPTINAV_BENCH_BEFORE"):
                try:
                    add(
                        "optinav read_imu, before (OPTINAV_BENCH_BEFORE)", _child("optinav", bag, REPEAT, BEFORE), label
                    )
                except RuntimeError as exc:  # an older optinav may refuse the file: a row that says so
                    print(f"  before: {label}: {str(exc)[-200:]}", file=sys.stderr)
                    nan = {"seconds": float("nan"), "peak_growth_mib": float("nan")}
                    add("optinav read_imu, before (OPTINAV_BENCH_BEFORE): refused the file", nan, label)
            add("optinav read_imu", _child("optinav", bag, REPEAT), label)
    return rows


def table(results: dict) -> str:
    """The Markdown table of a results JSON written by ``run.py --only readers`` (results_readers.md)."""
    rows, meta = results["rows"], results["meta"]
    ref = next(r["value"] for r in rows if r["method"].startswith("pyarrow") and r["metric"] == "Parquet: time")
    cells: dict = {}
    for r in rows:
        fmt, _, what = r["metric"].partition(": ")
        if what in ("time", "peak memory growth"):
            if r["group"] != rows[0]["group"]:  # another size: no ratio to the 1-hour Parquet read
                fmt = f"{fmt} ({r['group'].split(' IMU')[0].removeprefix('read ')} messages)"
            cells.setdefault((fmt, r["method"]), {"same": r["group"] == rows[0]["group"]})[what] = r["value"]
    out = [
        "# Reading a 1-hour 1 kHz IMU log (benchmarks/bench_readers.py)\n",
        f"{rows[0]['group']}; {meta['date']}, Python {meta['python']}, a shared 2-core machine (wall times vary "
        f"with the load). Best of {REPEAT} reads in one process for Parquet and for optinav's reading of bags, one read "
        "for rosbags and for a fresh process; peak memory is the growth of the resident set "
        "over the one after the imports.\n",
        "| file | method | time [s] | time / pyarrow | peak memory growth [MiB] |",
        "|---|---|---:|---:|---:|",
    ]
    for (fmt, method), v in cells.items():
        ratio = f"{v['time'] / ref:.1f}" if v["same"] else "—"
        out.append(
            f"| {fmt} | {method} | {v['time']:.2f} | {ratio} | {v.get('peak memory growth', float('nan')):.0f} |"
        )
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1].endswith(".json"):
        print(table(json.loads(Path(sys.argv[1]).read_text())), end="")
        sys.exit(0)
    quick = "--quick" in sys.argv
    out = run(quick)
    for r in out:
        print(f"{r['method']:<36} {r['metric']:<62} {r['value']:>12.4g} {r['unit']}")
