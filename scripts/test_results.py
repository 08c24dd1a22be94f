"""Tests of scripts/results.py: the tables it makes from bench reports, its errors, and that
docs/results.md and README.md are what it makes from the reports in docs/results-data/."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
import results  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
HEADER = "scene,integrator,run,seed,seconds,spp,passes,mse,rmse,rel_mse,speedup,variance,var_speedup\n"


def report(d, rows):
    d.mkdir(parents=True)
    lines = [HEADER]
    for name, mse, speedup, passes in rows:
        lines.append(f"s.toml,{name},0,0,1.0,{passes},{passes},{mse * 1.1},0,0,1,0,1\n")
        lines.append(f"s.toml,{name},median,0,1.0,{passes},{passes},{mse},0,0,{speedup},0,1\n")
    (d / "report.csv").write_text("".join(lines))


def test_grid_rows_cells_and_the_lowest_in_bold(tmp_path):
    report(tmp_path / "a", [("bdpt", 4e-2, 1.0, 100), ("vcm", 1e-2, 4.0, 80.5)])
    report(tmp_path / "b", [("bdpt", 2e-3, 1.0, 50), ("guided-bdpt:alpha=0.5", 3e-3, 0.667, 40)])
    table = results.grid([("A", str(tmp_path / "a")), ("B", str(tmp_path / "b"))])
    assert table.split("\n") == [
        "| integrator | A | B |",
        "|---|---|---|",
        "| bdpt | 4.00e-02 (1.00) [100] | **2.00e-03 (1.00) [50]** |",
        "| vcm | **1.00e-02 (4.00) [80.5]** | — |",
        "| guided-bdpt:alpha=0.5 | — | 3.00e-03 (0.67) [40] |",
    ]


def test_ratios_of_medians_and_the_seeds_each_wins(tmp_path):
    d = tmp_path / "a"
    d.mkdir()
    rows = [HEADER]
    for name, per_seed, median in [("pt", [4.0, 2.0, 3.0], 3.0), ("guided-pt", [1.0, 2.5, 1.5], 1.5)]:
        for seed, mse in enumerate(per_seed):
            rows.append(f"s.toml,{name},{seed},{seed},1.0,10,10,{mse},0,0,1,0,1\n")
        rows.append(f"s.toml,{name},median,0,1.0,10,10,{median},0,0,1,0,1\n")
    (d / "report.csv").write_text("".join(rows))
    extra = []
    assert results.parse_columns(["pool=a", "T=60", "pt:x=1/pt", "guided-pt/pt"], "w", extra) == [
        ("pool", "a")
    ]
    assert extra == ["pt:x=1/pt", "guided-pt/pt"]
    table = results.ratios([("pool", str(d))], ["guided-pt/pt", "pt/guided-pt", "vcm/pt"])
    assert table.split("\n") == [
        "| bench | guided-pt / pt | pt / guided-pt | vcm / pt |",
        "|---|---|---|---|",
        "| pool | 0.500x (2/3) | 2.000x (1/3) | — |",
    ]
    with pytest.raises(results.ResultsError, match="not a pair"):
        results.ratios([("pool", str(d))], ["guided-pt"])
    text = "<!-- results: ratios pool=a guided-pt/pt -->\n<!-- /results -->\n"
    assert "| pool | 0.500x (2/3) |" in results.update_text(text, "f.md", str(tmp_path))
    with pytest.raises(results.ResultsError, match="f.md:1: no bench ran 'guided-pt/pt'"):
        results.update_text(text.replace("ratios", "grid"), "f.md", str(tmp_path))


def test_stat_tables_take_the_median_over_runs(tmp_path):
    d = tmp_path / "a"
    d.mkdir()
    rows = ["scene,integrator,run,seed,key,value\n"]
    for run, v in enumerate([0.5, 0.9, 0.7]):
        rows.append(f"s.toml,guided-pt,{run},{run},failed_guided_share,{v}\n")
        rows.append(f"s.toml,guided-pt,{run},{run},seeder,outliers\n")
        rows.append(f"s.toml,pt,{run},{run},rays,{run}\n")
    (d / "stats.csv").write_text("".join(rows))
    table = results.stat([("pool", str(d))], ["failed_guided_share"])
    assert table.split("\n") == ["| integrator | pool |", "|---|---|", "| guided-pt | 0.7 |"]
    with pytest.raises(results.ResultsError, match="not a number"):
        results.stat([("pool", str(d))], ["seeder"])
    with pytest.raises(results.ResultsError, match="no run reports"):
        results.stat([("pool", str(d))], ["nothing"])
    with pytest.raises(results.ResultsError, match="one statistic"):
        results.stat([("pool", str(d))], [])


def test_grid_keeps_the_integrators_named_in_their_order(tmp_path):
    report(tmp_path / "a", [("bdpt", 4e-2, 1.0, 100), ("vcm", 1e-2, 4.0, 80)])
    table = results.grid([("A", str(tmp_path / "a"))], ["vcm"])
    assert table.split("\n")[2:] == ["| vcm | **1.00e-02 (4.00) [80]** |"]
    with pytest.raises(results.ResultsError, match="no bench ran 'pt'"):
        results.grid([("A", str(tmp_path / "a"))], ["pt"])


def test_update_replaces_marked_tables_only(tmp_path):
    report(tmp_path / "a", [("pt", 1e-3, 1.0, 10)])
    text = "intro\n<!-- results: grid T=60 x=a -->\nold\nold\n<!-- /results -->\n| untouched |\n"
    new = results.update_text(text, "f.md", str(tmp_path))
    assert new == (
        "intro\n<!-- results: grid T=60 x=a -->\n| integrator | x |\n|---|---|\n"
        "| pt | **1.00e-03 (1.00) [10]** |\n<!-- /results -->\n| untouched |\n"
    )


@pytest.mark.parametrize(
    "text, words",
    [
        ("<!-- results: grid x=missing -->\n<!-- /results -->\n", ["f.md:1", "missing", "report.csv"]),
        ("<!-- results: grid x=a -->\nno end\n", ["f.md:1", "<!-- /results -->"]),
        ("<!-- results: pie x=a -->\n<!-- /results -->\n", ["f.md:1", "unknown table kind 'pie'"]),
        ("<!-- results: grid T=1 -->\n<!-- /results -->\n", ["f.md:1", "no COLUMN=DIR"]),
    ],
)
def test_errors_name_the_file_line_and_problem(tmp_path, text, words):
    report(tmp_path / "a", [("pt", 1e-3, 1.0, 10)])
    with pytest.raises(results.ResultsError) as e:
        results.update_text(text, "f.md", str(tmp_path))
    for w in words:
        assert w in str(e.value)


def test_the_command_line_fails_cleanly_and_leaves_the_file(tmp_path):
    f = tmp_path / "r.md"
    f.write_text("<!-- results: grid x=nowhere -->\nkeep\n<!-- /results -->\n")
    p = subprocess.run([sys.executable, ROOT / "scripts" / "results.py", "update", f],
                       cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 1 and "nowhere" in p.stderr
    assert "keep" in f.read_text()


@pytest.mark.parametrize("doc", ["docs/results.md", "README.md"])
def test_committed_tables_are_what_the_reports_give(doc):
    text = (ROOT / doc).read_text()
    assert results.update_text(text, doc, str(ROOT)) == text, (
        f"{doc} is out of date: run `scripts/results.py update {doc}` from the repository root")
