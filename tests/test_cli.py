"""The command line: list, run, report, bench; bad input is one line and a non-zero exit."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from workbench.app import cli
from workbench.app import registry as problems


def call(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = cli.main(list(argv))
    except SystemExit as exc:  # argparse: --help and usage errors
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code: int, err: str, *, status: int = 2, match: str = "") -> None:
    assert code == status
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {lines}"
    assert "error" in lines[0] and match in lines[0]


def test_list_names_every_problem_with_its_title(capsys):
    code, out, _ = call(capsys, "list")
    assert code == 0
    lines = out.strip().splitlines()
    assert [ln.split()[0] for ln in lines] == problems.names()
    for ln, name in zip(lines, problems.names()):
        assert problems.title(name) in ln


@pytest.mark.parametrize("sub", [[], ["list"], ["run"], ["report"], ["bench"]])
def test_help_everywhere(capsys, sub):
    code, out, _ = call(capsys, *sub, "--help")
    assert code == 0 and "usage: workbench" in out


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["run", "no_such_problem"], "unknown problem 'no_such_problem'"),
        (["report", "no_such_problem"], "unknown problem(s) 'no_such_problem'"),
        (["report", "--bogus"], "unrecognized arguments: --bogus"),
        (["report", "--jobs", "0"], "--jobs: expected a whole number >= 1; got '0'"),
        (["report", "--jobs", "100000"],
         "--jobs: expected a whole number from 1 to 256 (problems run at the same time"),
        (["export-c", "s2_pd", "--out", "never-written", "--verify", "1000001"],
         "--verify must be an integer >= 0 and <= 1000000; got 1000001"),
        (["report", "--timeout", "-5"], "--timeout: expected a positive number; got '-5'"),
        (["report", "--timeout", "nan"], "--timeout: expected a positive number; got 'nan'"),
        (["report", "--memory", "0"], "--memory: expected a positive number; got '0'"),
        (["report", "chain_lqr", "--rerun", "chain_lq"],
         "--rerun: 'chain_lq' is not a problem of this report"),
        (["run"], "the following arguments are required: name"),
        ([], "the following arguments are required: COMMAND"),
        (["frobnicate"], "invalid choice: 'frobnicate'"),
        (["bench", "no_such_bench"], "unknown benchmark(s) 'no_such_bench'"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, argv, match):
    code, out, err = call(capsys, *argv)
    assert_one_line_error(code, err, match=match)
    assert out == ""


def test_unwritable_output_is_one_line_and_writes_nothing(capsys, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    code, out, err = call(capsys, "report", "pendulum3d_invariants", "--quick",
                          "--out", str(blocker / "out"))
    assert_one_line_error(code, err, match="--out: cannot create directory")
    code, _, err = call(capsys, "report", "--out", str(blocker))
    assert_one_line_error(code, err, match="exists and is not a directory")
    code, _, err = call(capsys, "run", "pendulum3d_invariants", "--json",
                        str(tmp_path / "missing" / "x.json"))
    assert_one_line_error(code, err, match="does not exist")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_entry_point_exit_status_and_one_line():
    proc = subprocess.run([sys.executable, "-m", "workbench.app.cli", "report", "nope"],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "unknown problem(s) 'nope'" in proc.stderr


def test_report_writes_html_with_progress_and_reuses_it(capsys, tmp_path, monkeypatch):
    from workbench.app.report import cache

    # the cache key hashes the engine's sources: others editing the shared checkout while
    # this test runs must not change it, so the engine hashed here is an empty one
    (tmp_path / "root" / "workbench").mkdir(parents=True)
    monkeypatch.setattr(cache, "ROOT", tmp_path / "root")
    out_dir, cache_dir = tmp_path / "out", tmp_path / "cache"
    argv = ("report", "pendulum3d_invariants", "--quick", "--html", "--out", str(out_dir),
            "--cache", str(cache_dir))
    code, out, err = call(capsys, *argv)
    assert code == 0
    assert sorted(p.name for p in out_dir.iterdir()) == ["report-quick-tables",
                                                          "report-quick.html"]
    assert f"wrote {out_dir / 'report-quick.html'}" in out
    assert "[1/1] pendulum3d_invariants" in err  # per-problem progress on stderr
    assert "elapsed" in err
    assert "1 run, 0 re-used" in out and "peak memory" in out  # the cost, at the end
    code, out, err = call(capsys, *argv)
    assert code == 0 and "re-used" in err and "0 run, 1 re-used" in out
    assert "since the command started" in out
    code, out, err = call(capsys, *argv, "--rerun", "pendulum3d_invariants")
    assert code == 0 and "1 run, 0 re-used" in out


def test_bench_lists_and_runs_scripts(capsys, tmp_path, monkeypatch):
    (tmp_path / "bench_fast.py").write_text("def main():\n    print('fast ratio 1.0')\n")
    (tmp_path / "bench_broken.py").write_text("def main():\n    raise ValueError('boom')\n")
    (tmp_path / "_helper.py").write_text("X = 1\n")
    monkeypatch.setattr(cli, "BENCHMARKS", tmp_path)
    code, out, _ = call(capsys, "bench", "--list")
    assert code == 0 and out.split()[::2] == ["broken", "fast"]
    code, out, err = call(capsys, "bench", "fast")
    assert code == 0 and "fast ratio 1.0" in out
    code, out, err = call(capsys, "bench")
    assert code == 1 and "fast ratio 1.0" in out
    assert "benchmark broken raised ValueError: boom" in err


def test_real_benchmarks_are_listed(capsys):
    code, out, _ = call(capsys, "bench", "--list")
    assert code == 0
    assert set(out.split()[::2]) == set(cli.benchmark_scripts())


def readme_problems(readme: Path) -> list[str]:
    """Problem names in the first column of the README's '## Problems' table."""
    text = readme.read_text(encoding="utf-8")
    m = re.search(r"^## Problems\s*$(.*?)(?=^## |\Z)", text, flags=re.M | re.S)
    assert m, "README.md has no '## Problems' section"
    return re.findall(r"^\|\s*`([A-Za-z0-9_]+)`\s*\|", m.group(1), flags=re.M)


def test_readme_lists_the_same_problems_as_workbench_list(capsys):
    code, out, _ = call(capsys, "list", "--markdown")
    assert code == 0
    listed = re.findall(r"^\| `([A-Za-z0-9_]+)` \|", out, flags=re.M)
    assert listed == problems.names()
    in_readme = readme_problems(Path(__file__).resolve().parents[1] / "README.md")
    missing = sorted(set(listed) - set(in_readme))
    extra = sorted(set(in_readme) - set(listed))
    assert not missing and not extra, (
        f"README.md's Problems table is out of date: missing {missing}, not a problem "
        f"{extra} (`workbench list --markdown` prints the table)")
