"""Running campaigns: serial and on a 2-worker LocalCluster give the same table bit for bit,
results are stored as they arrive (an interrupted campaign resumes, a finished one reruns
nothing), a failing scenario is a result row, the report."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from motionplc.campaign import load_campaign, run_campaign
from motionplc.campaign.report import report_html, report_text
from motionplc.cli import main
from tests.campaign.conftest import write_campaign

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client() -> Iterator[Any]:
    """One small LocalCluster for the module (2 processes on 127.0.0.1, no dashboard)."""
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        worker_dashboard_address=None,
        silence_logs=40,
    )
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_serial_and_local_cluster_tables_are_identical(
    small: Path, tmp_path: Path, client: Any
) -> None:
    c = load_campaign(small)
    serial = run_campaign(c, workers=0, output=tmp_path / "s", quiet=True)
    dask = run_campaign(c, client=client, batch=2, output=tmp_path / "d", quiet=True)
    assert serial.ran == dask.ran == len(c) == 4
    assert serial.digest == dask.digest
    assert [r["digest"] for r in serial.table] == [r["digest"] for r in dask.table]
    assert len({r["worker"] for r in dask.table}) == 2  # both workers ran scenarios
    # the figures are real: a faulted scenario stops on its fault, the others pass
    for r in serial.table:
        faults = json.loads(r["faults"])
        if r["param:faults[0].injected"]:
            assert faults and faults[0]["detected_s"] is not None
            assert faults[0]["detected_s"] <= 0.01 and r["end_time"] < 0.2
        else:
            assert r["program_ok"] and r["verdict"] == "pass"
            assert r["x.v_ratio"] <= 1 + 1e-6 and r["x.fe_max"] > 0
        assert (tmp_path / "s" / "results.parquet").is_file()


def test_interrupted_campaign_resumes_and_a_finished_one_reruns_nothing(
    small: Path, tmp_path: Path
) -> None:
    c = load_campaign(small)
    whole = run_campaign(c, workers=0, output=tmp_path / "whole", quiet=True)
    seen: list[int] = []

    def interrupt(rows: list[dict[str, Any]]) -> None:
        seen.extend(r["scenario"] for r in rows)
        if len(seen) >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_campaign(c, workers=0, batch=1, output=tmp_path / "cut", quiet=True, on_rows=interrupt)
    assert seen == [0, 1]
    again: list[int] = []
    rest = run_campaign(
        c,
        workers=0,
        output=tmp_path / "cut",
        quiet=True,
        on_rows=lambda rows: again.extend(r["scenario"] for r in rows),
    )
    assert again == [2, 3] and rest.ran == 2 and rest.reused == 2
    assert rest.digest == whole.digest
    done = run_campaign(c, workers=0, output=tmp_path / "cut", quiet=True)
    assert done.ran == 0 and done.reused == 4 and done.digest == whole.digest


def test_a_changed_campaign_reruns_only_what_changed(tmp_path: Path) -> None:
    body = "grid:\n  program.steps[1].call[0].velocity: [0.1, 0.2]\n"
    p = write_campaign(tmp_path, body)
    first = run_campaign(load_campaign(p), workers=0, output=tmp_path / "o", quiet=True)
    assert first.ran == 2
    p.write_text(p.read_text().replace("[0.1, 0.2]", "[0.1, 0.3]"))
    second = run_campaign(load_campaign(p), workers=0, output=tmp_path / "o", quiet=True)
    assert second.ran == 1 and second.reused == 1


def test_a_failing_scenario_is_a_result_row(tmp_path: Path, client: Any) -> None:
    # each value is valid alone; a following-error window of 0.1 µm stops the move (fail),
    # a wall-clock limit of 1 µs is a timeout, a value the validator refuses only in the
    # worker (a changed file) is an error: all rows, the campaign goes on
    body = "grid:\n  config.axes.x.following_error: [0.005, 1.0e-7]\n"
    p = write_campaign(tmp_path, body)
    res = run_campaign(load_campaign(p), client=client, output=tmp_path / "o", quiet=True)
    assert [r["verdict"] for r in res.table] == ["pass", "fail"]
    assert "FOLLOWING_ERROR" in res.table[1]["failures"].upper()
    p2 = write_campaign(tmp_path, "timeout: 0.000001\n", "t.yaml")
    c2 = load_campaign(p2)
    res1 = run_campaign(c2, workers=0, output=tmp_path / "t1", quiet=True)
    assert [r["verdict"] for r in res1.table] == ["timeout"]
    assert "wall-clock" in res1.table[0]["failures"]
    (tmp_path / "short.yaml").write_text("steps: 3\n")  # refused by the worker's validator
    res2 = run_campaign(c2, workers=0, output=tmp_path / "t", quiet=True)
    assert [r["verdict"] for r in res2.table] == ["error"]
    assert "short.yaml" in res2.table[0]["failures"]


def test_report_and_cli(small: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o"
    html = tmp_path / "r.html"
    code = main(
        ["campaign", str(small), "--workers", "0", "--out", str(out), "-q", "--report", str(html)]
    )
    text = capsys.readouterr().out
    assert code in (0, 1)
    assert "4 of 4 scenarios" in text and "worst scenarios:" in text
    assert f"motionplc campaign {small} --only" in text
    page = html.read_text()
    assert "plotly" in page.lower() and "Worst scenarios" in page
    res = run_campaign(load_campaign(small), workers=0, output=out, quiet=True)
    assert res.ran == 0
    assert "verdict over the varied parameters" in report_text(res)
    report_html(res, tmp_path / "again.html")
    assert main(["campaign", str(small), "--only", "1", "--out", str(out), "-q"]) in (0, 1)
    one = capsys.readouterr().out
    assert one.startswith("scenario 1: ")
    assert main(["campaign", str(small), "--scheduler", "tcp://10.1.2.3:8786"]) == 2
    assert "127.0.0.1" in capsys.readouterr().err
