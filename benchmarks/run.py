"""Run every benchmark and print one table; write the figures as JSON.

Each ``benchmarks/bench_*.py`` defines ``run(quick: bool) -> list[dict]``; a row is
``{"group": str, "method": str, "metric": str, "value": float, "unit": str}``, methods of one group
being compared side by side. Usage: ``python benchmarks/run.py [--quick] [--json FILE] [--only NAME]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _load(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller problem sizes (seconds, not minutes)")
    ap.add_argument("--json", default=str(HERE / "results.json"), help="where to write the figures")
    ap.add_argument("--only", default=None, help="run only bench_<NAME>.py")
    args = ap.parse_args(argv)
    rows = []
    for path in sorted(HERE.glob("bench_*.py")):
        if args.only and path.stem != f"bench_{args.only}":
            continue
        t0 = time.perf_counter()
        print(f"running {path.name} ...", file=sys.stderr, flush=True)
        rows.extend(_load(path).run(args.quick))
        print(f"  {path.name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    widths = [max(len(str(r[k])) for r in rows + [{k: k}]) for k in ("group", "method", "metric")]
    head = f"{'group':<{widths[0]}}  {'method':<{widths[1]}}  {'metric':<{widths[2]}}  {'value':>14}  unit"
    print(head)
    print("-" * len(head))
    for r in rows:
        print(
            f"{r['group']:<{widths[0]}}  {r['method']:<{widths[1]}}  {r['metric']:<{widths[2]}}  "
            f"{r['value']:>14.6g}  {r['unit']}"
        )
    meta = {
        "python": platform.python_version(),
        "machine": platform.machine(),
        "quick": args.quick,
        "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    Path(args.json).write_text(json.dumps({"meta": meta, "rows": rows}, indent=2) + "\n")
    print(f"figures written to {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
