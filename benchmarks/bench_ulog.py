"""Reading a 1-hour PX4 flight log (ULog) with ``optinav.io.read_imu``: time and peak memory.

The log is written here from the ULog format (PX4 "ULog File Format"), its messages in time order as PX4's
logger writes them: ``sensor_combined`` at 250 Hz (900 000 messages), ``vehicle_magnetometer`` at 50 Hz, and
20 other topics of 40-byte messages at 50 Hz each (what a logging profile adds beside the IMU: 3.6 M messages),
about 190 MB. Each reading runs in a fresh process with optinav and pyulog imported before the timing: the time of
``read_imu`` (sensor_combined, best of ``REPEAT``), of ``read_imu`` then ``optinav.io.ulog.ulog_mag`` (what
``attitude --mag`` reads: the magnetometer from the same parse), and of pyulog's own parse of the whole log (``ULog(path)``, every topic: what ``ulog2csv``
costs before writing), and the growth of the peak resident set over the resident set after the imports
(``VmHWM``/``VmRSS`` of ``/proc/self/status``, the peak reset through ``/proc/self/clear_refs``; Linux).
Quick: 5 minutes of log. ``python benchmarks/bench_ulog.py [--quick] [--out RESULTS.json]``.
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPEAT = 2
_CHILD = r"""
import json, sys, time
kind, path, repeat = sys.argv[1], sys.argv[2], int(sys.argv[3])
import numpy as np
import pyulog
from optinav.io import read_imu
from optinav.io import ulog
if kind == "optinav":
    read = lambda: (ulog._LAST.clear(), len(read_imu(path)))[1]
elif kind == "optinav-mag":  # what attitude --mag reads: the IMU's topic, then the magnetometer's of one parse
    read = lambda: (ulog._LAST.clear(), len(read_imu(path)), ulog.ulog_mag(path).t.size)[2]
else:
    read = lambda: sum(d.data["timestamp"].size for d in pyulog.ULog(path).data_list)

def status_kib(key):
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1])

best, n = float("inf"), 0
for _ in range(repeat):
    open("/proc/self/clear_refs", "w").write("5")  # reset the peak to the current resident set
    base = status_kib("VmRSS")
    t0 = time.perf_counter()
    n = read()
    best = min(best, time.perf_counter() - t0)
    peak = status_kib("VmHWM") - base
print(json.dumps({"kind": kind, "seconds": best, "rows": n, "peak_mib": peak / 1024}))
"""


def _msg_bytes(kind: str, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def write_log(path: Path, seconds: float, seed: int = 0) -> int:
    """The benchmark's log at ``path`` (see the module docs); returns its number of data messages."""
    rng = np.random.default_rng(seed)
    topics = [
        ("sensor_combined", 250.0, [("timestamp", "<u8", "uint64_t"), ("gyro_rad", ("<f4", 3), "float[3]"),
                                    ("gyro_integral_dt", "<u4", "uint32_t"),
                                    ("accelerometer_timestamp_relative", "<i4", "int32_t"),
                                    ("accelerometer_m_s2", ("<f4", 3), "float[3]"),
                                    ("accelerometer_integral_dt", "<u4", "uint32_t")]),
        ("vehicle_magnetometer", 50.0, [("timestamp", "<u8", "uint64_t"), ("timestamp_sample", "<u8", "uint64_t"),
                                        ("device_id", "<u4", "uint32_t"), ("magnetometer_ga", ("<f4", 3), "float[3]")]),
    ]  # fmt: skip
    other = [("timestamp", "<u8", "uint64_t"), ("values", ("<f4", 8), "float[8]")]
    topics += [(f"other_topic_{k}", 50.0, other) for k in range(20)]
    head = b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 0)
    defs = _msg_bytes("B", bytes(40))
    subs = b""
    records, stamps = [], []
    for msg_id, (name, rate, fields) in enumerate(topics):
        defs += _msg_bytes("F", f"{name}:{''.join(f'{t} {n};' for n, _, t in fields)}".encode())
        subs += _msg_bytes("A", struct.pack("<BH", 0, msg_id) + name.encode())
        n = int(seconds * rate)
        dt = np.dtype([(n_, f) for n_, f, _ in fields])
        rec = np.zeros(n, np.dtype([("size", "<u2"), ("type", "u1"), ("id", "<u2"), ("body", dt)]))
        rec["size"], rec["type"], rec["id"] = 2 + dt.itemsize, ord("D"), msg_id
        ts = 1_000_000 + np.round(np.arange(n) * 1e6 / rate).astype(np.int64) + msg_id
        rec["body"]["timestamp"] = ts
        for n_, f, _ in fields[1:]:
            shape = (n, f[1]) if isinstance(f, tuple) else (n,)
            if n_ == "timestamp_sample":
                rec["body"][n_] = ts - 500
            elif n_ != "accelerometer_timestamp_relative":
                rec["body"][n_] = rng.normal(size=shape)
        records.append(rec.view(np.uint8).reshape(n, rec.dtype.itemsize))
        stamps.append(ts)
    # all records in time order: each copied to its offset in one buffer
    order = np.argsort(np.concatenate(stamps), kind="stable")
    sizes = np.concatenate([np.full(r.shape[0], r.shape[1]) for r in records])[order]
    offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    out = np.empty(int(sizes.sum()), np.uint8)
    start = np.concatenate([[0], np.cumsum([r.shape[0] for r in records])])
    where = np.empty(order.size, np.int64)
    where[order] = offsets
    for k, r in enumerate(records):
        pos = where[start[k] : start[k + 1]]
        out[pos[:, None] + np.arange(r.shape[1])] = r
    with open(path, "wb") as fh:
        fh.write(head + defs + subs)
        fh.write(out.tobytes())
    return int(order.size)


def run(quick: bool) -> list[dict]:
    seconds = 300.0 if quick else 3600.0
    out = []
    with tempfile.TemporaryDirectory(prefix="optinav-bench-ulog-") as tmp:
        path = Path(tmp) / "flight.ulg"
        messages = write_log(path, seconds)
        mb = path.stat().st_size / 1e6
        for kind in ("optinav", "optinav-mag", "pyulog"):
            got = subprocess.run(
                [sys.executable, "-c", _CHILD, kind, str(path), str(REPEAT)], capture_output=True, text=True
            )
            if got.returncode:
                raise SystemExit(f"{kind}: {got.stderr.strip().splitlines()[-1]}")
            row = json.loads(got.stdout.strip().splitlines()[-1])
            row.update(log_seconds=seconds, file_mb=round(mb, 1), messages=messages)
            print(json.dumps(row), flush=True)
            out.append(row)
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="5 minutes of log instead of 1 hour")
    ap.add_argument("--out", help="write the results here (JSON)")
    a = ap.parse_args()
    results = run(a.quick)
    if a.out:
        Path(a.out).write_text(json.dumps(results, indent=1) + "\n")
