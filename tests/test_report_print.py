"""What the report prints and what it files: headline choice, CSV tables, escaping, load.

The PDF is the printed body; every table goes to the HTML (folded) and to a CSV file with
every value. These tests use a synthetic problem whose values hold a matrix wider and
longer than the HTML shows, a long vector, complex numbers, records, a list of more
matrices than the HTML shows, and hostile text (HTML, Typst markup, a spreadsheet
formula, quotes, commas, new lines, a path); its CSV files must give back exactly the
numbers of the result's JSON. The page count and the first page's figure of the PDF of a
real problem are checked in ``test_report.py``.
"""

from __future__ import annotations

import csv
import hashlib
import html
import io
import json
import math
import os
import re
import types
from pathlib import Path

import numpy as np
import pytest
from test_report import check_html, pdf_text

from workbench.app.report import Format, ReportInputError, build_report
from workbench.app.report.csvfiles import MARKER, csv_cell, safe_name
from workbench.app.report.frontpage import _headlines
from workbench.app.report.progress import Progress, load_share
from workbench.app.report.tables import MAX_COLS, MAX_ROWS, telling_order
from workbench.core.errors import ParameterError
from workbench.study._result import Comparison, Result, to_jsonable

HOSTILE = '<script>alert(1)</script> #panic("typst") $x$ *b* "q", c\nnext'
FORMULA = '=HYPERLINK("http://example.org","x")'


def hostile_result(*, quick: bool = False, extra: bool = True) -> Result:
    """A result with every kind of value the report lays out, and hostile text."""
    rng = np.random.default_rng(7)
    res = Result("hostile", "Hostile values (synthetic)", quick=quick)
    res.compare(f"quantity {HOSTILE}", 1.0, 1.0 + 1e-9, tolerance=1e-6, source="closed form")
    res.compare("printed value", 2.5, 2.5 + 4e-7, tolerance=1e-6, source="paper 002 (3)")
    res.compare("residual", 0.0, 1e-14, tolerance=1e-12, source="paper 002 (4)")
    vals = np.linspace(0.0, 1.0, 500) ** 3 / 7.0  # digits a 6-digit table would round
    res.values = {
        "A": rng.normal(size=(MAX_ROWS + 6, MAX_COLS + 3)),
        "long": vals,
        "eig": np.array([1.0 + 2.0j, -0.5 - 1e-17j, 3.0, 0.25j, 1 / 3 - 2 / 7j, 0.5, 0.75]),
        "runs": [{"case": HOSTILE, "formula": FORMULA, "error": 1 / 3, "nested": {"n": 2}},
                 {"case": "-starts with a minus", "error": float("nan"), "flag": True}],
        "stack": [rng.normal(size=(2, 2)) for _ in range(MAX_ROWS + 2)],
        "../../escape": {"x": 1.0, "y": [1, 2, 3]},
        "scalars": {"pi": math.pi, "huge": 1e300, "tiny": 5e-324, "neg": -0.1},
    }
    if extra:
        res.values["only_first_time"] = np.arange(40.0)
    return res.finish()


def catalogue(**kw) -> types.ModuleType:
    mod = types.ModuleType("hostile")
    mod.TITLE = "Hostile values (synthetic)"

    def solve(*, quick: bool = False) -> Result:
        res = hostile_result(quick=quick, **kw)
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(4, 2))
        ax.plot([0, 1, 2], [0, 1, 0])
        res.figure("curve", fig, caption=f"A curve; {HOSTILE}")
        return res

    mod.solve = solve
    cat = types.ModuleType("catalogue")
    cat.names = lambda: ["hostile"]
    cat.load = lambda name: mod
    cat.title = lambda name: mod.TITLE
    return cat


def read_csv(path: Path) -> list[list[str]]:
    with path.open(newline="", encoding="utf-8") as fh:
        return list(csv.reader(fh))


def parse(cell: str):
    """A CSV cell back to plain JSON data (the inverse of the report's writer)."""
    if cell in ("true", "false"):
        return cell == "true"
    if cell.startswith("["):
        return json.loads(cell)
    for kind in (int, float):
        try:
            return kind(cell)
        except ValueError:
            pass
    try:
        z = complex(cell)
    except ValueError:
        return cell
    return {"re": z.real, "im": z.imag}


def same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


@pytest.fixture(scope="module")
def hostile_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("hostile")
    rep = build_report(["hostile"], catalogue=catalogue(), out_dir=out, progress=False,
                       cache_dir=None)
    return rep, out, json.loads(json.dumps(hostile_result().as_dict()))


def test_csv_files_hold_every_value_of_the_result_json(hostile_report):
    rep, out, data = hostile_report
    folder = out / "report-tables" / "hostile"
    files = sorted(p.name for p in folder.iterdir())
    values = data["values"]
    # the matrix: every row and column (the HTML shows MAX_ROWS x MAX_COLS), unrounded
    rows = read_csv(folder / "A.csv")
    assert rows[0] == ["row"] + [str(j + 1) for j in range(MAX_COLS + 3)]
    got = [[float(c) for c in r[1:]] for r in rows[1:]]
    assert got == values["A"]  # exactly: the shortest repr of a float reads back to it
    # the long vector: all 500 entries, exactly
    rows = read_csv(folder / "long.csv")
    assert rows[0] == ["entry", "value"] and len(rows) == 501
    assert [float(r[1]) for r in rows[1:]] == values["long"]
    # complex numbers
    eig = [parse(r[1]) for r in read_csv(folder / "eig.csv")[1:]]
    assert eig == values["eig"]
    # records: every field, NaN as in the JSON, booleans as JSON's
    rows = read_csv(folder / "runs.csv")
    header = rows[0]
    assert header == ["#", "case", "formula", "error", "nested.n", "flag"]
    first = dict(zip(header, rows[1]))
    assert first["case"] == HOSTILE  # the csv module quotes the comma, quote and new line
    assert first["formula"] == "'" + FORMULA  # a spreadsheet would run it: made text
    assert float(first["error"]) == values["runs"][0]["error"]
    second = dict(zip(header, rows[2]))
    assert second["case"] == "'-starts with a minus" and second["flag"] == "true"
    assert second["error"] == values["runs"][1]["error"] == "nan"
    # every item of a long list of matrices, including those the HTML does not show
    for i in range(MAX_ROWS + 2):
        rows = read_csv(folder / f"stack-{i}.csv")
        assert [[float(c) for c in r[1:]] for r in rows[1:]] == values["stack"][i]
    # scalars of a group: their quantity and exact value
    pairs = {r[0]: parse(r[1]) for r in read_csv(folder / "scalars.csv")[1:]}
    assert all(same(pairs[k], v) for k, v in values["scalars"].items()), pairs
    # the comparisons: every field of each
    rows = read_csv(folder / "comparisons.csv")
    assert len(rows) == 1 + len(data["comparisons"])
    for row, comp in zip(rows[1:], data["comparisons"]):
        parsed = dict(zip(rows[0], row))
        assert parsed["quantity"] == comp["quantity"]
        for key in ("reference", "workbench", "deviation", "tolerance"):
            assert float(parsed[key]) == comp[key], key
        assert parsed["ok"] == str(comp["ok"]).lower()
    # a hostile key cannot leave the folder; names are plain
    assert "escape.csv" in files
    assert all(re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*\.csv", f) for f in files), files
    assert all(p.resolve().is_relative_to(out.resolve()) for p in out.rglob("*"))
    assert set(rep.tables) == {p for p in (out / "report-tables").rglob("*.csv")}


def test_html_folds_the_tables_links_the_csv_files_and_escapes(hostile_report):
    rep, out, _ = hostile_report
    check_html(out / "report.html")  # balanced, no script, no external reference
    text = (out / "report.html").read_text()
    assert "<script>" not in text and html.escape("<script>alert(1)</script>") in text
    assert '<details id="appendix-hostile">' in text
    assert text.count('<details class="table">') >= 3  # the matrix, the vector, the records
    links = re.findall(r'href="(report-tables/[^"]+\.csv)"', text)
    assert "report-tables/hostile/A.csv" in links and "report-tables/hostile/stack-25.csv" in links
    for link in links:
        assert (out / html.unescape(link)).is_file(), link
    # tables past MAX_ROWS items of a list are listed as CSV only, not shown
    assert "more tables (items of long lists), as CSV only" in text


def test_pdf_prints_hostile_text_as_text_and_the_telling_headline(hostile_report):
    rep, out, _ = hostile_report
    text = pdf_text(out / "report.pdf")
    # the caption (and the quantity) are printed literally, not run as Typst markup
    assert '<script>alert(1)</script> #panic("typst") $x$ *b* "q", c next' in text
    assert "Appendix" not in text and "(30×15)" not in text  # the matrix is not printed
    # the headline: none out of tolerance, so the paper's printed value first, then the
    # closed form, then the residual (a zero reference)
    (sec,) = rep.document.problems
    assert [r[0] for r in sec.headline.rows] == ["printed value", f"quantity {HOSTILE}",
                                                "residual"]
    assert rep.document.headlines.rows[0][:2] == ["hostile", "printed value"]
    assert "printed value" in text and "paper 002 (3)" in text


def test_headline_is_the_most_telling_comparison():
    c = [Comparison("zero residual", 0.0, 1e-9, 1e-8, "paper 1 (2)"),      # margin 0.9
         Comparison("closed form", 2.0, 2.0 + 1e-10, 1e-8, "closed form"),  # non-zero ref
         Comparison("printed, far", 3.0, 3.0 + 1e-12, 1e-6, "paper 1 (3)"),
         Comparison("printed, near", 4.0, 4.0 + 9e-7, 1e-6, "Paper 1 Table 2"),
         Comparison("printed count", 2, 2, 0, "paper 1 Prop. 3")]
    assert [x.quantity for x in telling_order(c)] == [
        "printed, near", "printed, far", "printed count", "closed form", "zero residual"]
    flagged = Comparison("flagged", 0.0, 0.0, 1e-9, "closed form", headline=True)
    out = Comparison("out", 0.0, 1.0, 1e-9, "closed form")
    assert [x.quantity for x in telling_order([*c, flagged, out])][:3] == [
        "out", "flagged", "printed, near"]
    # the front page's table picks the same from the summary rows; rows cached before the
    # headline flag (7 items) are read too
    rows = [[x.quantity, x.reference, x.workbench, x.deviation, x.tolerance, x.ok, x.source,
             x.headline] for x in c]
    outcome = types.SimpleNamespace(name="p", summary={"headline": rows})
    assert _headlines([outcome]).rows[0][1] == "printed, near"
    outcome.summary["headline"] = [r[:7] for r in rows]
    assert _headlines([outcome]).rows[0][1] == "printed, near"


def test_compare_headline_flag_is_optional_and_checked():
    res = Result("r", "t")
    assert res.compare("a", 1.0, 1.0, tolerance=0, source="s").headline is False
    assert res.compare("b", 1.0, 1.0, tolerance=0, source="s", headline=True).as_dict()[
        "headline"] is True
    with pytest.raises(ParameterError, match="headline must be True or False; got 'yes'"):
        res.compare("c", 1.0, 1.0, tolerance=0, source="s", headline="yes")
    assert len(res.comparisons) == 2


def test_csv_cells_round_trip_and_names_are_safe():
    for v in (0.1, -1e-300, 1 / 3, 2.0**60, 7, True, None, "plain"):
        cell = csv_cell(to_jsonable(v))
        assert same(parse(cell), v) or (v is None and cell == "")
    assert complex(csv_cell({"re": -0.5, "im": 1 / 3})) == complex(-0.5, 1 / 3)
    for text, want in (("=1+1", "'=1+1"), ("+x", "'+x"), ("@sum", "'@sum"), ("-inf", "-inf"),
                       ("-1.5e3", "-1.5e3"), ("\tx", "'\tx")):
        assert csv_cell(text) == want
    taken: set[str] = set()
    names = [safe_name(t, taken) for t in ("../../x", ".hidden", "A", "a", "", "é/ü",
                                           "L1+.ends", "L1-.ends", "-rf x")]
    assert names == ["x", "hidden", "A", "a-2", "table", "table-2", "L1+.ends", "L1-.ends",
                     "rf-x"]


def test_foreign_tables_folder_is_refused_and_only_own_files_are_removed(tmp_path):
    out = tmp_path / "out"
    folder = out / "report-tables"
    out.mkdir()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    for make, what in ((lambda: folder.write_text("x"), "is not a folder"),
                       (lambda: folder.symlink_to(elsewhere), "is a symbolic link")):
        make()
        with pytest.raises(ReportInputError, match=what):
            build_report(["hostile"], catalogue=catalogue(), out_dir=out, progress=False,
                         cache_dir=None, formats=[Format.HTML])
        assert sorted(p.name for p in out.iterdir()) == ["report-tables"]
        folder.unlink()
    assert list(elsewhere.iterdir()) == []
    folder.mkdir()
    (folder / "mine.txt").write_text("a user's file")
    with pytest.raises(ReportInputError, match="did not write .*mine.txt"):
        build_report(["hostile"], catalogue=catalogue(), out_dir=out, progress=False,
                     cache_dir=None, formats=[Format.HTML])
    assert sorted(p.name for p in out.iterdir()) == ["report-tables"]  # nothing written
    (folder / "mine.txt").unlink()
    build_report(["hostile"], catalogue=catalogue(), out_dir=out, progress=False,
                 cache_dir=None, formats=[Format.HTML])
    assert (folder / MARKER).is_file()
    assert (folder / "hostile" / "only_first_time.csv").is_file()
    (folder / "hostile" / "notes.txt").write_text("a user's note, put here later")
    (folder / "mine.txt").write_text("a user's file, put here later")
    build_report(["hostile"], catalogue=catalogue(extra=False), out_dir=out, progress=False,
                 cache_dir=None, formats=[Format.HTML])
    # the table the problem no longer has is removed; what the user put there stays
    assert not (folder / "hostile" / "only_first_time.csv").exists()
    assert (folder / "hostile" / "notes.txt").read_text() == "a user's note, put here later"
    assert (folder / "mine.txt").is_file() and (folder / "hostile" / "A.csv").is_file()
    listed = json.loads((folder / MARKER).read_text())["files"]
    assert "hostile/A.csv" in listed and "hostile/only_first_time.csv" not in listed
    assert "mine.txt" not in listed


def test_time_estimate_is_scaled_by_the_load():
    assert load_share(2, load=0.0, cores=2).share == 1.0
    assert load_share(2, load=2.0, cores=2).share == pytest.approx(0.5)   # 2 / (2 + 2)
    assert load_share(2, load=6.0, cores=4).share == pytest.approx(0.5)   # 4 / (6 + 2)
    assert load_share(4, load=0.0, cores=2).share == pytest.approx(0.5)   # more than cores
    assert load_share(1, load=0.5, cores=8).share == 1.0
    assert load_share(2, load=float("nan"), cores=2).share == 1.0         # unknown: idle
    # the printed line: 2 problems of 60 s and 40 s on 2 processes take 60 s on an idle
    # machine; with a load of 2 on 2 cores each process gets half a core: 120 s
    out = io.StringIO()
    show = Progress(2, stream=out, enabled=True, jobs=2, load=2.0, cores=2)
    show.plan({"a": 60.0, "b": 40.0})
    line = out.getvalue()
    assert "about 2:00 by the last runs (1:00 on an idle machine;" in line, line
    assert "load average 2.00 on 2 cores: about 50% of a core for each of the report's 2" in line
    assert show.remaining() == pytest.approx((120.0 + 80.0) / 2)
    show.started("a")  # what it took last time is said as it was measured
    show.step("a", {"message": "orbit"})
    assert "took 1:00 last time" in out.getvalue().splitlines()[-1]
    idle = io.StringIO()
    Progress(2, stream=idle, enabled=True, jobs=2, load=0.0, cores=2).plan({"a": 60.0})
    assert ("about 1:00 by the last runs (load average 0.00 on 2 cores: about 100% of a core "
            "for the report's process)") in idle.getvalue()


# ----------------------------------------------------------------------------------------
# the tables folder: the report replaces or removes only its own files nobody edited


def two_problems(solved: Path | None, **kw) -> types.ModuleType:
    """The hostile problem under two names; each run adds a line to the file ``solved`` (the
    problems run in other processes)."""
    base = catalogue(**kw)
    cat = types.ModuleType("catalogue")
    cat.names = lambda: ["hostile", "other"]

    def load(name):
        mod = types.ModuleType(name)
        mod.TITLE = name

        def solve(*, quick: bool = False) -> Result:
            if solved is not None:
                with solved.open("a") as fh:
                    fh.write(name + "\n")
            return base.load("hostile").solve(quick=quick)

        mod.solve = solve
        return mod

    cat.load = load
    cat.title = lambda name: name
    return cat


def report(out: Path, name: str, solved: Path | None = None, **kw):
    return build_report([name], catalogue=two_problems(solved, **kw), out_dir=out,
                        progress=False, cache_dir=None, formats=[Format.HTML])


def snapshot(out: Path) -> dict[str, bytes]:
    return {p.relative_to(out).as_posix(): (p.read_bytes() if p.is_file() else b"")
            for p in sorted(out.rglob("*"))}


def test_the_marker_records_each_files_sha256(tmp_path):
    report(tmp_path, "hostile")
    folder = tmp_path / "report-tables"
    mark = json.loads((folder / MARKER).read_text())
    on_disk = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.csv"))
    assert sorted(mark["sha256"]) == on_disk and len(on_disk) >= 5
    for rel, digests in mark["sha256"].items():
        assert digests == [hashlib.sha256((folder / rel).read_bytes()).hexdigest()]
    assert set(mark["files"]) == {*on_disk, "hostile/"}


@pytest.mark.parametrize("next_problem", ["other", "hostile"])
def test_an_edited_table_stops_the_report_before_anything_runs_or_is_written(tmp_path,
                                                                            next_problem):
    """Whether the next report would remove the edited file (another problem) or replace it
    (the same one): it names the file, runs nothing and writes nothing."""
    solved, tmp_path = tmp_path / "solved.txt", tmp_path / "out"
    report(tmp_path, "hostile", solved)
    edited = tmp_path / "report-tables" / "hostile" / "comparisons.csv"
    edited.write_text(edited.read_text() + "my note,,\n")
    before = snapshot(tmp_path)
    with pytest.raises(ReportInputError, match=r"hostile/comparisons\.csv \(edited since\);"
                                               r" nothing was written"):
        report(tmp_path, next_problem, solved)
    assert solved.read_text().split() == ["hostile"], "refused before any problem ran"
    assert snapshot(tmp_path) == before
    # moved away by the user: the report removes its own (unedited) files and folder
    edited.rename(tmp_path / "mine.csv")
    report(tmp_path, next_problem, solved)
    tables = tmp_path / "report-tables"
    assert (tables / "hostile").is_dir() == (next_problem == "hostile")
    assert (tables / next_problem / "comparisons.csv").is_file()
    assert (tmp_path / "mine.csv").read_text().endswith("my note,,\n")


def test_a_file_the_report_did_not_write_at_a_new_tables_name_stops_it(tmp_path):
    """Found only once the problem ran (the table is new): still before anything is written.
    The same file holding exactly the new table is not a conflict."""
    report(tmp_path, "hostile", extra=False)
    theirs = tmp_path / "report-tables" / "hostile" / "only_first_time.csv"
    theirs.write_text("a user's table\n")
    before = snapshot(tmp_path)
    with pytest.raises(ReportInputError, match=r"only_first_time\.csv \(not written by the "
                                               r"report\)"):
        report(tmp_path, "hostile", extra=True)
    assert snapshot(tmp_path) == before
    other = tmp_path / "elsewhere"
    report(other, "hostile", extra=True)
    theirs.write_bytes((other / "report-tables" / "hostile" / "only_first_time.csv")
                       .read_bytes())
    report(tmp_path, "hostile", extra=True)
    assert json.loads((tmp_path / "report-tables" / MARKER).read_text())["sha256"][
        "hostile/only_first_time.csv"] == [hashlib.sha256(theirs.read_bytes()).hexdigest()]


def test_links_and_read_only_tables_stop_the_report_and_are_kept(tmp_path):
    report(tmp_path, "hostile")
    folder = tmp_path / "report-tables"
    secret = tmp_path / "secret.txt"
    secret.write_text("not the report's")
    (folder / "hostile" / "A.csv").unlink()
    (folder / "hostile" / "A.csv").symlink_to(secret)
    with pytest.raises(ReportInputError, match=r"hostile/A\.csv \(now a symbolic link\)"):
        report(tmp_path, "other")
    assert secret.read_text() == "not the report's"
    (folder / "hostile" / "A.csv").unlink()
    os.chmod(folder / "hostile" / "long.csv", 0o444)
    before = snapshot(tmp_path)
    with pytest.raises(ReportInputError, match=r"long\.csv' is read-only \(mode 0444\)"):
        report(tmp_path, "hostile")
    assert snapshot(tmp_path) == before


def test_an_interrupted_report_leaves_only_files_the_next_one_may_replace(tmp_path,
                                                                          monkeypatch):
    """While the files are written the marker lists both the old and the new digests: after
    a failure before the final marker, a replaced table (the cost table, whose timings
    change with every run) is still the report's own, and so are the new problem's."""
    from workbench.app.report import csvfiles

    report(tmp_path, "hostile", extra=False)
    folder = tmp_path / "report-tables"
    cost = folder / "hostile" / "cost-and-accuracy.csv"
    first = cost.read_bytes()
    real, markers = csvfiles.write_atomic, []

    def failing(path, data, **kw):
        if Path(path).name == MARKER:
            markers.append(data)
            if len(markers) == 2:  # the final marker, after every table was written
                raise ReportInputError("--out: injected fault")
        return real(path, data, **kw)

    monkeypatch.setattr(csvfiles, "write_atomic", failing)
    with pytest.raises(ReportInputError, match="injected fault"):
        build_report(["hostile", "other"], catalogue=two_problems(None, extra=False),
                     out_dir=tmp_path, progress=False, cache_dir=None, formats=[Format.HTML])
    monkeypatch.undo()
    assert cost.read_bytes() != first, "the cost table must have been replaced"
    interim = json.loads((folder / MARKER).read_text())["sha256"]
    assert len(interim["hostile/cost-and-accuracy.csv"]) == 2
    report(tmp_path, "hostile", extra=True)
    assert not (folder / "other").exists()
    assert sorted(json.loads((folder / MARKER).read_text())["sha256"]) == sorted(
        p.relative_to(folder).as_posix() for p in folder.rglob("*.csv"))


def test_a_marker_without_digests_replaces_only_identical_files(tmp_path):
    """An older report's marker cannot show a file unedited: what the report would remove,
    or replace by other content (the cost table's timings change with every run), stops
    it; a table it writes again with the same content (the values) goes through."""
    report(tmp_path, "hostile", extra=True)
    folder = tmp_path / "report-tables"
    old = json.loads((folder / MARKER).read_text())
    (folder / MARKER).write_text(json.dumps({"what": old["what"], "files": old["files"]}))
    before = snapshot(tmp_path)
    for extra, names in ((True, ["cost-and-accuracy.csv"]),
                         (False, ["cost-and-accuracy.csv", "only_first_time.csv"])):
        with pytest.raises(ReportInputError) as info:
            report(tmp_path, "hostile", extra=extra)
        named = re.findall(r"hostile/([\w.-]+) \(recorded without its SHA-256 by an older "
                           r"report", str(info.value))
        assert named == names, str(info.value)
        assert snapshot(tmp_path) == before
    (folder / "hostile" / "cost-and-accuracy.csv").unlink()  # moved away by the user
    report(tmp_path, "hostile", extra=True)
    new = json.loads((folder / MARKER).read_text())["sha256"]
    assert sorted(new) == sorted(old["sha256"])
    assert new["hostile/A.csv"] == old["sha256"]["hostile/A.csv"]


def test_a_read_only_report_file_stops_the_report_before_any_problem_runs(tmp_path):
    from workbench.core.errors import OutputError

    solved, out = tmp_path / "solved.txt", tmp_path / "out"
    report(out, "hostile", solved)
    os.chmod(out / "report.html", 0o444)
    before = snapshot(out)
    with pytest.raises(OutputError, match=r"report\.html' is read-only \(mode 0444\)"):
        report(out, "other", solved)
    assert solved.read_text().split() == ["hostile"], "refused before any problem ran"
    assert snapshot(out) == before  # the tables too: nothing was written
