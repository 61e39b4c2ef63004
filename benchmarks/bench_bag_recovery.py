"""Reading bags whose recording did not close: the cost of the readable copy, beside the closed bag's read.

1 M ``sensor_msgs/msg/Imu`` messages (1 kHz, 17 min; quick: 50 000) written by rosbags' writers
(:mod:`bench_readers`'s messages), then left as a recording that did not close leaves them: a ROS 1 bag without
index whose last chunk is still open (``X.bag.active``: the header's index position and the open chunk's sizes 0,
as ros_comm's writer leaves them until close), an MCAP file without summary, footer and closing magic, and a
rosbag2 sqlite3 file whose second half is only in its write-ahead log (``X.db3-wal``, the resilient profile).
Methods side by side, each read in a fresh process (the closed bag best of 3; the one left open read once, the
copy made in the timing: a second read in a process reuses it; peak memory as in :mod:`bench_readers`):
``optinav read_imu`` of the closed bag, and of the one left open (reindexed, closed or folded into a copy in a
temporary folder first). ``python benchmarks/bench_bag_recovery.py RESULTS.json`` prints the Markdown table.
"""

from __future__ import annotations

import json
import shutil
import sqlite3
import struct
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_readers as br  # noqa: E402

REPEAT = 3


def _ros1_open(bag: Path, out: Path) -> Path:
    """``bag`` as its recording leaves it when killed: no index, the last chunk open (sizes 0)."""
    from optinav.io import bagscan

    idx = bagscan.ros1_index(bag)
    raw = bytearray(bag.read_bytes())
    f, _, _ = bagscan._record(raw, len(bagscan._ROS1_MAGIC), len(raw))
    pos = idx["chunks"][-1][0]
    g, ds, de = bagscan._record(raw, pos, len(raw))
    raw = raw[:de]
    raw[g[b"size"][0] : g[b"size"][0] + 4] = bytes(4)
    raw[ds - 4 : ds] = bytes(4)
    raw[f[b"index_pos"][0] : f[b"index_pos"][0] + 8] = bytes(8)
    out.write_bytes(raw)
    return out


def _mcap_open(bag: Path, out: Path) -> Path:
    """The MCAP file of the bag folder ``bag`` cut where its data section ends (no summary, footer, magic)."""
    raw = next(bag.glob("*.mcap")).read_bytes()
    pos = 8
    while raw[pos] not in (0x0F, 0x02):
        pos += 9 + struct.unpack_from("<Q", raw, pos + 1)[0]
    out.write_bytes(raw[:pos])
    return out


def _sqlite_logged(bag: Path, out: Path) -> Path:
    """The .db3 of the bag folder ``bag`` with its second half of messages only in a write-ahead log beside it,
    copied while the writer holds it open."""
    db3 = next(bag.glob("*.db3"))
    con = sqlite3.connect(db3)
    rows = con.execute("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id").fetchall()
    half = len(rows) // 2
    con.execute("DELETE FROM messages WHERE id > ?", (rows[half - 1][0],))
    con.commit()
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("PRAGMA wal_autocheckpoint=0")
    con.executemany("INSERT INTO messages VALUES (?, ?, ?, ?)", rows[half:])
    con.commit()
    out.mkdir()
    for f in (db3, db3.with_name(db3.name + "-wal")):
        shutil.copyfile(f, out / f.name)
    con.close()
    return out / db3.name


def run(quick: bool) -> list[dict]:
    n = 50_000 if quick else 1_000_000
    ns, acc, gyr = br._samples(n)
    group = f"read {n} IMU messages of a recording that did not close"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        cases = (
            ("ros1", "ROS 1 bag", lambda b: _ros1_open(b, d / "rec.bag.active"), "without index, last chunk open"),
            ("mcap", "ROS 2 mcap bag", lambda b: _mcap_open(b, d / "rec_0.mcap"), "without summary and footer"),
            ("sqlite3", "ROS 2 sqlite3 bag", lambda b: _sqlite_logged(b, d / "wal"), "half in its write-ahead log"),
        )
        for kind, label, leave, how in cases:
            bag = br._write_bag(d / f"imu_{kind}", kind, ns, acc, gyr)
            br._check(bag, ns, acc, gyr)
            closed = br._child("optinav", bag, REPEAT)
            left = leave(bag)
            opened = br._child("optinav", left, 1)  # one read: a second in the process reuses the copy
            if opened["n"] < n - 2000:  # an open ROS 1 chunk keeps its complete records: all of them here
                raise RuntimeError(f"{left.name}: {opened['n']} of {n} messages read")
            for method, res in (("closed", closed), (how, opened)):
                for metric, key, unit in (("time", "seconds", "s"), ("peak memory growth", "peak_growth_mib", "MiB")):
                    rows.append({"group": group, "method": f"optinav read_imu, {label} {method}",
                                 "metric": metric, "value": res[key], "unit": unit})  # fmt: skip
            rows.append({"group": group, "method": f"optinav read_imu, {label} {how}", "metric": "messages read",
                         "value": opened["n"], "unit": "-"})  # fmt: skip
    return rows


def table(results: dict) -> str:
    """The Markdown table of a results JSON written by ``run.py --only bag_recovery``."""
    rows, meta = results["rows"], results["meta"]
    cells: dict = {}
    for r in rows:
        cells.setdefault(r["method"], {})[r["metric"]] = r["value"]
    out = [
        "# Reading bags whose recording did not close (benchmarks/bench_bag_recovery.py)\n",
        f"{rows[0]['group']}; {meta['date']}, Python {meta['python']}, a shared 2-core machine. A fresh process "
        f"for each: the closed bag best of {REPEAT} reads, the one left open one read (its copy made in the "
        "timing); peak memory is the growth of the resident set over the one after the imports.\n",
        "| bag | time [s] | peak memory growth [MiB] | messages read |",
        "|---|---:|---:|---:|",
    ]
    for method, v in cells.items():
        read = f"{v['messages read']:.0f}" if "messages read" in v else "all"
        out.append(f"| {method} | {v['time']:.2f} | {v['peak memory growth']:.0f} | {read} |")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1].endswith(".json"):
        print(table(json.loads(Path(sys.argv[1]).read_text())), end="")
        sys.exit(0)
    for r in run("--quick" in sys.argv):
        print(f"{r['method']:<70} {r['metric']:<20} {r['value']:>12.4g} {r['unit']}")
