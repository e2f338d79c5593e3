"""The report of a campaign: a summary in the terminal and an HTML page with plots (plotly):
verdicts over the varied parameters, distributions of following error, end time and fault
reaction time, and the worst scenarios with the command that reruns one alone."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any

from motionplc.campaign.engine import CampaignResult

__all__ = ["report_html", "report_text", "worst"]

_ORDER = {"error": 0, "timeout": 1, "fail": 2, "pass": 3}


def _quantiles(xs: list[float]) -> tuple[float, float, float, float]:
    s = sorted(xs)
    n = len(s)

    def q(p: float) -> float:
        return s[min(n - 1, max(0, math.ceil(p * n) - 1))]

    return s[0], q(0.5), q(0.95), s[-1]


def _num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _fe_sum(r: dict[str, Any]) -> float:
    return sum(v for k, v in r.items() if k.endswith(".fe_max") and _num(v))


def worst(table: list[dict[str, Any]], n: int = 10) -> list[dict[str, Any]]:
    """The scenarios to look at first: errors, timeouts, failures, then the largest
    following errors."""
    return sorted(table, key=lambda r: (_ORDER.get(r["verdict"], 0), -_fe_sum(r), r["scenario"]))[
        :n
    ]


def _groups(table: list[dict[str, Any]], col: str) -> list[tuple[str, list[dict[str, Any]]]]:
    """Rows by the value of a parameter: each value when there are few, else 4 ranges."""
    vals = [r.get(col) for r in table]
    distinct = sorted({v for v in vals if v is not None}, key=lambda v: (str(type(v)), v))
    if len(distinct) <= 6 or not all(_num(v) for v in distinct):
        return [(_fmt(v), [r for r in table if r.get(col) == v]) for v in distinct]
    xs = sorted(v for v in vals if _num(v))
    edges = [xs[min(len(xs) - 1, (len(xs) * k) // 4)] for k in range(4)] + [xs[-1]]
    out = []
    for k in range(4):
        lo, hi = edges[k], edges[k + 1]
        rows = [
            r
            for r in table
            if _num(r.get(col)) and lo <= r[col] and (r[col] < hi or (k == 3 and r[col] <= hi))
        ]
        if rows:
            out.append((f"{_fmt(lo)} .. {_fmt(hi)}", rows))
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        if v.is_integer() and abs(v) < 1e6 and abs(v) > 0.5:
            return f"{v:g}"
        return f"{v:.4g}"
    return str(v)


def _pass_rate(rows: list[dict[str, Any]]) -> str:
    n = len(rows)
    p = sum(1 for r in rows if r["verdict"] == "pass")
    return f"{p}/{n} pass ({100.0 * p / n:.0f} %)" if n else "-"


def _axes(table: list[dict[str, Any]]) -> list[str]:
    out: list[str] = []
    for r in table:
        for k in r:
            if k.endswith(".fe_max"):
                a = k[: -len(".fe_max")]
                if a not in out:
                    out.append(a)
    return out


def _first_line(text: Any) -> str:
    s = str(text or "").strip().splitlines()
    line = s[0] if s else ""
    return line if len(line) <= 160 else line[:157] + "..."


def report_text(result: CampaignResult, n_worst: int = 8) -> str:
    """The terminal summary."""
    c, table = result.campaign, result.table
    lines = []
    counts = ", ".join(
        f"{result.counts.get(v, 0)} {v}" for v in ("pass", "fail", "error", "timeout")
    )
    rate = result.ran / result.seconds if result.seconds > 0 and result.ran else 0.0
    lines.append(f"campaign {c.name}: {len(table)} of {len(c)} scenarios: {counts}")
    how = {"serial": "serially", "local": f"on a LocalCluster of {result.workers} workers"}.get(
        result.mode, f"on the scheduler's {result.workers} workers"
    )
    lines.append(
        f"  ran {result.ran} now {how} in {result.seconds:.1f} s"
        + (f" ({rate:.2f} scenarios/s)" if rate else "")
        + f", {result.reused} already stored; results in {result.output}"
    )
    lines.append(f"  result table digest {result.digest[:16]}")
    params = [k for k in (table[0] if table else {}) if k.startswith("param:")]
    if params:
        lines.append("")
        lines.append("verdict over the varied parameters:")
        for col in params:
            lines.append(f"  {col[6:]}:")
            for label, rows in _groups(table, col):
                lines.append(f"    {label:>28}: {_pass_rate(rows)}")
    ran = [r for r in table if r["verdict"] in ("pass", "fail")]
    if ran:
        lines.append("")
        lines.append(f"{'figure':<28} {'min':>11} {'median':>11} {'p95':>11} {'max':>11}")
        figs = [("end time [s]", "end_time")]
        for a in _axes(table):
            figs += [
                (f"{a} following error", f"{a}.fe_max"),
                (f"{a} |v| / v_max", f"{a}.v_ratio"),
                (f"{a} |a| / a_max", f"{a}.a_ratio"),
                (f"{a} |j| / j_max", f"{a}.j_ratio"),
            ]
        figs.append(("fault reaction [s]", "reaction_max_s"))
        for label, col in figs:
            xs = [r[col] for r in ran if _num(r.get(col))]
            if xs:
                q = _quantiles(xs)
                lines.append(f"{label:<28} " + " ".join(f"{x:>11.4g}" for x in q))
        over = {
            a: sum(
                1
                for r in ran
                if any(
                    _num(r.get(f"{a}.{k}_ratio")) and r[f"{a}.{k}_ratio"] > 1.0 + 1e-6
                    for k in "vaj"
                )
            )
            for a in _axes(table)
        }
        beyond = ", ".join(f"{a}: {n}" for a, n in over.items() if n)
        if beyond:
            lines.append(
                f"set values beyond an axis limit (by differencing, > 1 + 1e-6): {beyond} scenarios"
            )
        ov = sum(int(r.get("overruns") or 0) for r in ran)
        lines.append(f"overruns: {ov}")
    bad = worst(table, n_worst)
    if bad:
        lines.append("")
        lines.append("worst scenarios:")
        for r in bad:
            fe = ", ".join(
                f"{a} {r.get(f'{a}.fe_max'):.3g}"
                for a in _axes(table)
                if _num(r.get(f"{a}.fe_max"))
            )
            lines.append(
                f"  #{r['scenario']:<6} {r['verdict']:<8} fe {fe or '-'}; "
                f"{_first_line(r.get('failures')) or 'no failure'}"
            )
            lines.append(f"          {c.rerun_command(r['scenario'])}")
    return "\n".join(lines)


def report_html(result: CampaignResult, path: str | Path) -> Path:
    """Write the HTML report (plotly, self-contained) to ``path``."""
    import plotly.graph_objects as go
    import plotly.io as pio
    from plotly.subplots import make_subplots

    c, table = result.campaign, result.table
    colors = {"pass": "#2ca02c", "fail": "#d62728", "error": "#7f7f7f", "timeout": "#ff7f0e"}
    params = [k for k in (table[0] if table else {}) if k.startswith("param:")]
    figs: list[Any] = []
    if params:
        cols = 2 if len(params) > 1 else 1
        rows_n = math.ceil(len(params) / cols)
        fig = make_subplots(rows=rows_n, cols=cols, subplot_titles=[p[6:] for p in params])
        for i, col in enumerate(params):
            rr, cc = divmod(i, cols)
            for v in ("pass", "fail", "error", "timeout"):
                rows = [r for r in table if r["verdict"] == v]
                if not rows:
                    continue
                fig.add_trace(
                    go.Scatter(
                        x=[r.get(col) for r in rows],
                        y=[r.get("end_time") for r in rows],
                        mode="markers",
                        name=v,
                        legendgroup=v,
                        showlegend=i == 0,
                        marker={"color": colors[v], "size": 6, "opacity": 0.7},
                        text=[f"#{r['scenario']}" for r in rows],
                    ),
                    row=rr + 1,
                    col=cc + 1,
                )
            fig.update_yaxes(title_text="end time [s]", row=rr + 1, col=cc + 1)
        fig.update_layout(
            title="Verdict over the varied parameters (y: end time)", height=320 * rows_n
        )
        figs.append(fig)
    axes = _axes(table)
    ran = [r for r in table if r["verdict"] in ("pass", "fail")]
    hists = [(f"{a} max following error", f"{a}.fe_max") for a in axes]
    hists += [("end time [s]", "end_time"), ("fault reaction [s]", "reaction_max_s")]
    hists = [(t, k) for t, k in hists if any(_num(r.get(k)) for r in ran)]
    if hists:
        fig = make_subplots(rows=1, cols=len(hists), subplot_titles=[t for t, _ in hists])
        for i, (_t, k) in enumerate(hists):
            for v in ("pass", "fail"):
                xs = [r[k] for r in ran if r["verdict"] == v and _num(r.get(k))]
                if xs:
                    fig.add_trace(
                        go.Histogram(
                            x=xs,
                            name=v,
                            legendgroup=v,
                            showlegend=i == 0,
                            marker={"color": colors[v]},
                            opacity=0.75,
                        ),
                        row=1,
                        col=i + 1,
                    )
        fig.update_layout(title="Distributions", barmode="stack", height=360)
        figs.append(fig)
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>campaign {html.escape(c.name)}</title>",
        "<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}pre{background:#f6f6f6;"
        "padding:1em}</style></head><body>",
        f"<h1>Campaign {html.escape(c.name)}</h1>",
        f"<pre>{html.escape(report_text(result, n_worst=0))}</pre>",
    ]
    for i, fig in enumerate(figs):
        parts.append(
            pio.to_html(
                fig, include_plotlyjs=(i == 0), full_html=False, config={"responsive": True}
            )
        )
    parts.append("<h2>Worst scenarios</h2><table><tr><th>#</th><th>verdict</th>")
    parts.append("".join(f"<th>{html.escape(a)} fe max</th>" for a in axes))
    parts.append("<th>end time</th><th>parameters</th><th>first failure</th><th>rerun</th></tr>")
    for r in worst(table, 20):
        fe = "".join(
            f"<td>{r.get(f'{a}.fe_max'):.4g}</td>" if _num(r.get(f"{a}.fe_max")) else "<td>-</td>"
            for a in axes
        )
        et = r.get("end_time")
        params_text = ", ".join(f"{p}={_fmt(v)}" for p, v in json.loads(r.get("params") or "[]"))
        parts.append(
            f"<tr><td>{r['scenario']}</td><td style='color:{colors.get(r['verdict'], '#000')}'>"
            f"{r['verdict']}</td>{fe}<td>{'' if not _num(et) else f'{et:.3f}'}</td>"
            f"<td>{html.escape(params_text)}</td>"
            f"<td>{html.escape(_first_line(r.get('failures')))}</td>"
            f"<td><code>{html.escape(c.rerun_command(r['scenario']))}</code></td></tr>"
        )
    parts.append("</table></body></html>")
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text("\n".join(parts), encoding="utf-8")
    return p
