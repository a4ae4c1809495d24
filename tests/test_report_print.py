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
import html
import io
import json
import math
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
