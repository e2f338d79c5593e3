"""``motionplc campaign CAMPAIGN.yaml``: the command line of :mod:`motionplc.campaign`."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["add_command"]


def _nonneg(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"got {text!r} (allowed: an integer >= 0)") from None
    if n < 0:
        raise argparse.ArgumentTypeError(f"got {n} (allowed: an integer >= 0)")
    return n


def add_command(command: Callable[[str, str], argparse.ArgumentParser]) -> None:
    """Register ``campaign`` with the CLI's ``command(name, help)`` factory."""
    p = command(
        "campaign",
        "run a scenario campaign (grids, random draws, fault injections) on Dask",
    )
    p.add_argument("campaign", help="campaign file (YAML, see docs/reference/campaign.md)")
    p.add_argument(
        "--workers",
        type=_nonneg,
        default=None,
        metavar="N",
        help="LocalCluster worker processes on 127.0.0.1 (default: execution.workers, else one "
        "per core); 0: serially in this process, without Dask",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="an existing Dask scheduler, tcp://127.0.0.1:PORT (default: execution.scheduler, "
        "else a LocalCluster)",
    )
    p.add_argument(
        "--batch",
        type=_nonneg,
        default=None,
        metavar="N",
        help="scenarios per Dask task (default: execution.batch, else automatic)",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="results directory (default: execution.output, else out/campaigns/<name>)",
    )
    p.add_argument(
        "--report",
        metavar="FILE.html",
        help="write the HTML report (plots) too (default: the terminal summary only)",
    )
    p.add_argument(
        "--only",
        type=_nonneg,
        action="append",
        metavar="N",
        help="run scenario N alone (repeatable) and print its figures (default: every scenario)",
    )
    p.add_argument(
        "--trace",
        action="store_true",
        help="keep each scenario's trace (Parquet) under DIR/traces/ (default: execution.trace, "
        "else none)",
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="validate the campaign and list its varied parameters; run nothing (default: run)",
    )
    p.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="no progress bar (default: a bar with its ETA on stderr)",
    )
    p.set_defaults(func=cmd_campaign)


def cmd_campaign(args: argparse.Namespace) -> int:
    from motionplc.campaign import load_campaign, run_campaign
    from motionplc.campaign.report import report_html, report_text

    c = load_campaign(args.campaign)
    if args.report is not None and not args.report.lower().endswith((".html", ".htm")):
        from motionplc.errors import MotionPlcError

        raise MotionPlcError(f"--report: {args.report!r} (allowed: a .html file)")
    for w in c.warnings:
        print(w, file=sys.stderr)
    if args.check:
        print(
            f"ok: {c.path}: {len(c)} scenarios ({c.grid_points} grid points x {c.draws} draws); "
            f"varied: {', '.join(c.parameters) or 'nothing'}"
        )
        return 0
    if args.only:
        res = run_campaign(
            c,
            workers=0,
            output=args.out,
            trace=args.trace or None,
            quiet=args.quiet,
            only=args.only,
            rerun=True,
        )
        for row in res.table:
            _print_row(row)
        return 0 if all(r["verdict"] == "pass" for r in res.table) else 1
    res = run_campaign(
        c,
        workers=args.workers,
        scheduler=args.scheduler,
        batch=args.batch or None,
        output=args.out,
        trace=args.trace or None,
        quiet=args.quiet,
    )
    print(report_text(res))
    if args.report is not None:
        print(f"wrote {report_html(res, args.report)}")
    return 0 if all(r["verdict"] == "pass" for r in res.table) else 1


def _print_row(row: dict[str, Any]) -> None:
    print(f"scenario {row['scenario']}: {row['verdict']} (key {row['key']})")
    for k, v in row.items():
        if k in ("scenario", "verdict", "key", "params", "faults", "failures"):
            continue
        print(f"  {k}: {v}")
    for f in json.loads(row.get("faults") or "[]"):
        print(
            f"  fault {f['fault']} on {f['axis']} at {f['at']:.4f} s: detected after "
            f"{f['detected_s']} s, set velocity 0 after {f['at_rest_s']} s"
        )
    for line in str(row.get("failures") or "").splitlines():
        print(f"  FAILED: {line}")
