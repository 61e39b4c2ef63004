"""``optinav reproduce``: run the registered studies and write the report folder."""

from __future__ import annotations

import argparse
import sys
import textwrap

from optinav.cli.common import SEED, shared_data_dir
from optinav.reports import available_studies, check_report_dir, get_study, run_studies, write_report


def register(sub) -> None:
    studies = available_studies()
    listing = "\n".join(f"  {k:<12} {v}" for k, v in studies.items())
    p = sub.add_parser(
        "reproduce",
        help="reproduce the papers' tables and figures and the core checks into a report folder",
        description="Run studies on built-in simulated data and write DIR/index.md, index.html, "
        "summary.json and PNG figures.",
        epilog=textwrap.dedent(f"""\
            studies:
            {listing}
              all          every study (default)

            example:
              optinav reproduce --quick --out optinav-report
              (then open optinav-report/index.html)
            """),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("study", nargs="?", default="all", help="study name or 'all' (default)")
    p.add_argument("--quick", action="store_true", help="smaller versions of each study (minutes, not tens)")
    p.add_argument("--out", default="optinav-report", help="report folder (default: optinav-report)")
    p.add_argument("--seed", type=SEED, default=2026, help="random seed (default 2026)")
    p.set_defaults(func=run)


def run(args) -> int:
    from optinav.core.progress import is_quiet, progress_enabled
    from optinav.reports.report import report_option

    names = list(available_studies()) if args.study == "all" else [args.study]
    for name in names:
        get_study(name)  # unknown names fail before any work
    check_report_dir(args.out, "--out")

    def announce(name):
        if not progress_enabled() and not is_quiet():
            print(f"optinav: study {name} ...", file=sys.stderr, flush=True)  # a log, when no bar is shown

    # studies that read real data take the shared data folder, resolved here (the library takes paths)
    results = run_studies(names, quick=args.quick, seed=args.seed, data_dir=shared_data_dir(), announce=announce)
    with report_option("--out"):
        out = write_report(results, args.out, title="optinav reproduce" + (" (quick)" if args.quick else ""))
    failed = [f"{r.name}: {c.name}" for r in results for c in r.checks if not c.passed]
    n = sum(len(r.checks) for r in results)
    print(f"optinav: report written to {out}/index.md ({n - len(failed)}/{n} checks passed)")
    for f in failed:
        print(f"optinav: check failed: {f}", file=sys.stderr)
    return 1 if failed else 0
