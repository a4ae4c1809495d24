"""The report: formulas, symbolic vector fields, tables, HTML in a real browser, PDF pages.

The default run uses a synthetic catalogue (a real model from models/, two tiny problems,
one of which fails) and one real problem in quick mode; the full report of every problem
is the slow test at the end. Chromium and poppler-utils come from `make test-deps`; when
they are missing the browser and PDF tests fail (they do not skip).
"""

from __future__ import annotations

import html
import html.entities
import re
import shutil
import subprocess
import types
import xml.etree.ElementTree as ET
from html.parser import HTMLParser
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import sympy as sp

from models import pendulum3d as p3
from models.chain_cart import chain_cart
from models.spherical import spherical_pendulum
from workbench.app import registry as problems
from workbench.app.report import Format, ReportInputError, Status, build_report
from workbench.app.report.latexmath import LatexError, to_mathml, to_typst
from workbench.app.report.symbolic import (
    casadi_to_sympy,
    parameter_symbols,
    state_symbols,
    vector_field_rows,
)
from workbench.study._result import Result

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": [0.0, 0.0, 0.3]}
VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source",
        "track", "wbr"}


def all_model_equations() -> list[str]:
    models = [
        p3.full(**BODY), p3.reduced(**BODY), p3.routh(**BODY, mu=0.1),
        p3.routh_reconstruction(**BODY, mu=0.1),
        p3.spinning_top(Jt=0.2, Ja=0.05, rho_s=0.3, spin=1.0), p3.planar(Jt=0.2, rho_s=0.3),
        spherical_pendulum(), chain_cart(2),
    ]
    return [e for m in models for e in m.equations]


def need(tool: str) -> str:
    path = shutil.which(tool)
    if path is None:
        pytest.fail(f"{tool} is not installed; run 'make test-deps' (installs chromium and "
                    "poppler-utils with apt-get)")
    return path


# ----------------------------------------------------------------------------------------
# formulas


def typst_compiles(formulas: list[str], tmp_path: Path) -> None:
    import typst

    src = "\n".join(f"$ {f} $" for f in formulas)
    (tmp_path / "m.typ").write_text(src)
    pdf = typst.compile(str(tmp_path / "m.typ"))
    assert pdf[:4] == b"%PDF"


def test_every_model_equation_converts_to_mathml_and_typst(tmp_path):
    eqs = all_model_equations()
    assert len(eqs) >= 15
    typ = []
    for e in eqs:
        ml = to_mathml(e)
        root = ET.fromstring(ml)  # well-formed XML
        assert root.tag == "{http://www.w3.org/1998/Math/MathML}math"
        assert root.get("alttext") == e
        typ.append(to_typst(e))
    typst_compiles(typ, tmp_path)


def test_latex_structure_is_kept():
    ml = to_mathml(r"\frac{a}{b} + x_i^2 + \dot\omega \times \Gamma")
    for tag in ("<mfrac>", "<msubsup>", '<mover><mi>ω</mi><mo>˙</mo></mover>', "<mo>×</mo>",
                "<mi>Γ</mi>"):
        assert tag in ml
    ty = to_typst(r"\frac{a, b}{c} + R_{hor}^T + \text{(5.1)}")
    assert ty.startswith(r"frac(a \, b, c)")
    assert "attach(R, b: h o r, t: T)" in ty and '"(5.1)"' in ty


@pytest.mark.parametrize("bad", [r"\unknowncommand x", r"\frac{a}{b", r"x^{2", r"\sqrt[3]{x}",
                                 r"\begin{align} x \end{align}", "a}"])
def test_unsupported_latex_raises(bad):
    with pytest.raises(LatexError):
        to_mathml(bad)


# ----------------------------------------------------------------------------------------
# vector fields read from the casadi graph


def test_casadi_to_sympy_matches_casadi(rng):
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    expr = ca.vertcat(ca.sin(x[0]) * p[0] + x[1] ** 2 / p[1], ca.sqrt(x[2]) - ca.atan2(x[0], 2),
                      ca.exp(-x[1]) * ca.cos(p[0]) + 2.5)
    fn = ca.Function("f", [x, p], [expr])
    xs, ps = sp.symbols("x0:3"), sp.symbols("p0:2")
    (out,) = casadi_to_sympy(fn, [list(xs), list(ps)])
    for _ in range(5):
        xv, pv = rng.uniform(0.5, 2.0, 3), rng.uniform(0.5, 2.0, 2)
        subs = dict(zip(xs + ps, np.r_[xv, pv]))
        got = [float(e.subs(subs)) for e in out]
        np.testing.assert_allclose(got, np.asarray(fn(xv, pv)).ravel(), rtol=1e-13)


def test_vector_field_of_a_model_equals_its_rhs(rng):
    model = spherical_pendulum(m=0.7, l=1.3)
    assert vector_field_rows(model).rows == []  # nothing built yet: nothing read, nothing built
    assert len(model.build_log) == 0
    model.function("f")
    sheet = vector_field_rows(model)
    assert len(model.build_log) == 1  # typesetting built nothing more
    # the kinematic rows (q-dot = omega x q) are small enough to print symbolically; the
    # dynamic rows of the Lagrangian-derived field may be too long to typeset (omitted)
    forms = [r.form for r in sheet.rows]
    assert forms[:3] == ["symbolic"] * 3 and set(forms) <= {"symbolic", "numeric", "omitted"}
    fn = model.function("f")
    xs, ps = state_symbols(model), parameter_symbols(model)
    us = [sp.Symbol(f"u_{k + 1}") for k in range(3)]
    (xdot,) = casadi_to_sympy(fn, [xs, us, ps])
    q = rng.normal(size=3)
    q /= np.linalg.norm(q)
    x, u = np.r_[q, np.cross(rng.normal(size=3), q)], rng.normal(size=3)
    subs = dict(zip(xs + us + ps, np.r_[x, u, model.p]))
    np.testing.assert_allclose([float(e.subs(subs)) for e in xdot], model.rhs(x, u),
                               rtol=1e-12, atol=1e-12)
    # the typeset LaTeX is sympy's printing of that expression
    assert sheet.rows[0].latex == sp.latex(xdot[0])


# ----------------------------------------------------------------------------------------
# a synthetic catalogue: one problem on a real model, one that fails


def make_catalogue(length: float) -> types.ModuleType:
    good = types.ModuleType("good")
    good.TITLE = "Spherical pendulum small oscillations (synthetic)"

    def solve(*, quick: bool = False) -> Result:
        res = Result("good", good.TITLE, quick=quick)
        model = spherical_pendulum(l=length)
        res.use(model)
        with res.timed("linearisation"):
            A = np.asarray(model.function("f_x")([0, 0, 1, 0, 0, 0], np.zeros(3), model.p))
            eig = np.linalg.eigvals(A)
        res.compare("hanging frequency sqrt(g/l) [rad/s]", 3.1321, float(np.max(eig.imag)),
                    tolerance=1e-4, source="paper 002 (printed, l = 1)")
        res.values = {"eigenvalues": eig, "A": A, "tolerance": 1e-12}
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(4, 3))
        ax.plot(eig.real, eig.imag, "o", color="#d62728", ms=12)
        res.figures["spectrum"] = fig
        return res.finish()

    good.solve = solve
    bad = types.ModuleType("broken")
    bad.TITLE = "A problem that raises"

    def boom(*, quick: bool = False) -> Result:
        raise RuntimeError("deliberate failure for the report test")

    bad.solve = boom
    mods = {"good": good, "broken": bad}
    cat = types.ModuleType("catalogue")
    cat.names = lambda: sorted(mods)
    cat.load = lambda name: mods[name]
    cat.title = lambda name: mods[name].TITLE
    return cat


class TableGrabber(HTMLParser):
    """Rows of the tables with a given class."""

    def __init__(self, cls: str) -> None:
        super().__init__()
        self.cls, self.depth, self.rows, self.cell = cls, 0, [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table" and self.cls in (a.get("class") or "").split():
            self.depth = 1
        elif self.depth and tag == "tr":
            self.rows.append([])
        elif self.depth and tag in ("td", "th"):
            self.cell = ""

    def handle_endtag(self, tag):
        if tag == "table":
            self.depth = 0
        elif self.depth and tag in ("td", "th") and self.cell is not None:
            self.rows[-1].append(self.cell.strip())
            self.cell = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell += data


def comparison_rows(path: Path) -> list[list[str]]:
    g = TableGrabber("full")  # the appendix's full table (the headline one omits sources)
    g.feed(path.read_text())
    return [r for r in g.rows if r and r[0] != "quantity"]


def test_failing_problem_is_reported_not_fatal(tmp_path):
    rep = build_report(quick=True, formats=[Format.HTML], out_dir=tmp_path,
                       catalogue=make_catalogue(1.0), progress=False, cache_dir=None)
    assert [r.name for r in rep.runs] == ["broken", "good"]
    assert rep.failed == ["broken"] and not rep.ok
    assert rep.runs[1].status is Status.OK
    text = (tmp_path / "report-quick.html").read_text()
    assert "RuntimeError: deliberate failure for the report test" in text
    assert "Spherical pendulum small oscillations (synthetic)" in text
    assert "spherical_pendulum.f_x" in text  # the build log: what this problem built


def test_paper_vs_workbench_table_is_computed(tmp_path):
    out1, out2 = tmp_path / "l1", tmp_path / "l2"
    for length, out in ((1.0, out1), (2.0, out2)):
        build_report(["good"], formats=[Format.HTML], out_dir=out,
                     catalogue=make_catalogue(length), progress=False, cache_dir=None)
    (r1,), (r2,) = comparison_rows(out1 / "report.html"), comparison_rows(out2 / "report.html")
    assert r1[0] == r2[0] == "hanging frequency sqrt(g/l) [rad/s]"
    assert r1[2] == r2[2] == "3.1321"  # the printed value is the same
    assert float(r1[3]) == pytest.approx(np.sqrt(9.81 / 1.0), rel=1e-9)
    assert float(r2[3]) == pytest.approx(np.sqrt(9.81 / 2.0), rel=1e-9)
    assert r1[-1] == "ok" and r2[-1] == "OUT"
    assert float(r2[4].split()[0]) == pytest.approx(abs(np.sqrt(9.81 / 2) - 3.1321), rel=1e-2)


def test_bad_input_fails_before_anything_runs(tmp_path):
    cat = make_catalogue(1.0)
    with pytest.raises(ReportInputError, match="unknown problem"):
        build_report(["nope"], out_dir=tmp_path, catalogue=cat, progress=False, cache_dir=None)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ReportInputError, match="not a directory|Not a directory"):
        build_report(out_dir=blocker / "sub", catalogue=cat, progress=False, cache_dir=None)
    with pytest.raises(ReportInputError, match="not a directory"):
        build_report(out_dir=blocker, catalogue=cat, progress=False, cache_dir=None)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_no_partial_files_when_pdf_fails(tmp_path, monkeypatch):
    import workbench.app.report.pdf as pdf
    from workbench.app.report import ReportError

    def fail(doc):
        raise ReportError("typst failed: simulated")

    monkeypatch.setattr(pdf, "render_pdf", fail)
    with pytest.raises(ReportError):
        build_report(["good"], out_dir=tmp_path, catalogue=make_catalogue(1.0),
                     progress=False, cache_dir=None)
    # the CSV tables and the HTML that links them are written before the PDF
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report-tables", "report.html"]


# ----------------------------------------------------------------------------------------
# HTML: parses cleanly, needs no network, renders in Chromium with figures and tables


class StrictHTML(HTMLParser):
    """Balanced elements, known entities, no external resources."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=False)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.counts: dict[str, int] = {}

    def handle_starttag(self, tag, attrs):
        self.counts[tag] = self.counts.get(tag, 0) + 1
        for k, v in attrs:
            if k in ("src", "href") and v and re.match(r"[a-z]+:", v):
                self.errors.append(f"external reference <{tag} {k}={v!r}>")
        if tag in ("script", "link", "iframe", "object"):
            self.errors.append(f"<{tag}> present")
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.counts[tag] = self.counts.get(tag, 0) + 1

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes <{self.stack[-1] if self.stack else None}> "
                               f"at line {self.getpos()[0]}")
        else:
            self.stack.pop()

    def handle_entityref(self, name):
        if name + ";" not in html.entities.html5:
            self.errors.append(f"unknown entity &{name};")


def check_html(path: Path) -> StrictHTML:
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    p = StrictHTML()
    p.feed(text)
    p.close()
    assert not p.errors, p.errors[:10]
    assert p.stack == [], f"unclosed elements {p.stack}"
    return p


def screenshot(page: Path, png: Path, tmp_path: Path, *, height: int = 2000) -> np.ndarray:
    from PIL import Image

    chromium = need("chromium")
    cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", "--hide-scrollbars", f"--user-data-dir={tmp_path / 'chromium'}",
           f"--screenshot={png}", f"--window-size=1280,{height}", page.resolve().as_uri()]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)
    assert proc.returncode == 0 and png.is_file(), proc.stderr[-2000:]
    return np.asarray(Image.open(png).convert("RGB")).astype(int)


def pixels_near(img: np.ndarray, rgb: tuple[int, int, int], tol: int = 12) -> int:
    return int(np.sum(np.all(np.abs(img - np.array(rgb)) <= tol, axis=-1)))


def pdf_text(pdf: Path) -> str:
    need("pdftotext")
    out = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                         text=True, check=True, timeout=120).stdout
    return re.sub(r"\s+", " ", out)


def pdf_pages(pdf: Path) -> int:
    need("pdfinfo")
    info = subprocess.run(["pdfinfo", str(pdf)], capture_output=True, text=True, check=True,
                          timeout=60).stdout
    return int(re.search(r"Pages:\s+(\d+)", info).group(1))


def render_pdf_pages(pdf: Path, tmp_path: Path, *, first: int, last: int) -> list[np.ndarray]:
    from PIL import Image

    need("pdftoppm")
    subprocess.run(["pdftoppm", "-png", "-r", "50", "-f", str(first), "-l", str(last), str(pdf),
                    str(tmp_path / "page")], check=True, timeout=120, capture_output=True)
    files = sorted(tmp_path.glob("page-*.png"))
    assert len(files) == last - first + 1
    return [np.asarray(Image.open(f).convert("RGB")).astype(int) for f in files]


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    """The quick report of one real problem and the synthetic ones, HTML and PDF."""
    out = tmp_path_factory.mktemp("report")
    rep = build_report(["pendulum3d_invariants"], quick=True, out_dir=out, progress=False,
                       cache_dir=tmp_path_factory.mktemp("cache"))
    return rep, out


def test_html_parses_cleanly_and_is_self_contained(quick_report):
    rep, out = quick_report
    p = check_html(out / "report-quick.html")
    assert p.counts.get("svg", 0) >= 1  # the figure, inline
    assert p.counts.get("math", 0) >= 10  # equations, parameters, vector fields
    assert p.counts.get("table", 0) >= 8
    text = (out / "report-quick.html").read_text()
    for quantity, *_ in rep.runs[0].summary["headline"]:
        assert html.escape(quantity) in text
    # a document first: the plain-language summary and the first page's sections
    assert html.escape(rep.document.problems[0].summary) in text
    assert "Errata of the papers that this report confirms" in text
    assert text.count('<details id="appendix-') == len(rep.runs)  # the appendix, folded


def test_html_renders_in_chromium_with_figures_and_tables(quick_report, tmp_path):
    _, out = quick_report
    # tall enough for the first page (status, headline numbers, errata) and the first figure
    img = screenshot(out / "report-quick.html", tmp_path / "shot.png", tmp_path, height=3600)
    assert img.shape[1] == 1280
    white = pixels_near(img, (255, 255, 255), tol=3)
    assert white < 0.97 * img.shape[0] * img.shape[1], "page looks blank"
    # figures: matplotlib's first two line colours are drawn
    assert pixels_near(img, (31, 119, 180), tol=20) > 300, "no blue figure lines visible"
    assert pixels_near(img, (255, 127, 14), tol=20) > 300, "no orange figure lines visible"
    # tables: header fill and cell borders of the report's CSS
    assert pixels_near(img, (243, 245, 248), tol=2) > 2000, "no table headers visible"
    assert pixels_near(img, (208, 215, 222), tol=6) > 2000, "no table borders visible"
    # the status badge (green) is visible
    assert pixels_near(img, (26, 127, 55), tol=10) > 100


def test_pdf_pages_text_and_rendering(quick_report, tmp_path):
    """The PDF is the printed body: a figure on page 1, each problem's headline comparisons,
    figures and notes; the full tables are in the HTML and the CSV files, not here."""
    rep, out = quick_report
    pdf = out / "report-quick.pdf"
    n = pdf_pages(pdf)
    # the first pages (status, headline numbers, errata, findings: 2), the problem (its
    # headline table, figure and notes: 1) and the environment (1); the appendix of full
    # tables made it 8 pages for this one problem
    assert 3 <= n <= 4, n
    text = pdf_text(pdf)
    run = rep.runs[0]
    assert re.sub(r"\s+", " ", run.title) in text
    assert "Appendix: full tables" not in text
    assert "Functions built" not in text and "Cost and accuracy" not in text
    assert "Vector field read from the built graph" not in text
    assert "report-quick-tables/" in text  # where the full tables are
    for quantity, *_ in run.summary["headline"][:3]:
        assert quantity in text
    for note in rep.document.problems[0].notes:
        assert re.sub(r"\s+", " ", note)[:40] in text
    pages = render_pdf_pages(pdf, tmp_path, first=1, last=min(n, 3))
    for img in pages:
        assert pixels_near(img, (255, 255, 255), tol=3) < 0.995 * img.shape[0] * img.shape[1]
    # page 1 has a figure: the problem's own (its matplotlib blue and orange lines)
    assert pixels_near(pages[0], (31, 119, 180), tol=25) > 50
    assert pixels_near(pages[0], (255, 127, 14), tol=25) > 50
    cover = rep.document.cover
    assert cover is not None and cover.problem == run.name
    page1 = subprocess.run(["pdftotext", "-f", "1", "-l", "1", "-layout", str(pdf), "-"],
                           capture_output=True, text=True, check=True, timeout=60).stdout
    assert re.sub(r"\s+", " ", cover.figure.caption)[:40] in re.sub(r"\s+", " ", page1)


def test_report_lists_every_problem_of_the_catalogue(tmp_path):
    cat = make_catalogue(1.0)
    rep = build_report(quick=True, formats=[Format.PDF], out_dir=tmp_path, catalogue=cat,
                       progress=False, cache_dir=None)
    text = pdf_text(tmp_path / "report-quick.pdf")
    for name in cat.names():
        assert name in text and cat.title(name) in text
    assert [row[0] for row in rep.document.summary.rows] == cat.names()


# ----------------------------------------------------------------------------------------
# the full report of every problem


@pytest.mark.slow
def test_full_report_of_every_problem(tmp_path):
    names = problems.names()  # before: others may add problems while the report runs
    rep = build_report(out_dir=tmp_path, progress=False, cache_dir=tmp_path / "cache")
    assert [r.name for r in rep.runs] == names
    p = check_html(tmp_path / "report.html")
    assert p.counts.get("section", 0) >= len(names)
    img = screenshot(tmp_path / "report.html", tmp_path / "full.png", tmp_path, height=4000)
    assert pixels_near(img, (243, 245, 248), tol=2) > 2000
    text = pdf_text(tmp_path / "report.pdf")
    assert pdf_pages(tmp_path / "report.pdf") >= len(names)
    for run in rep.runs:
        assert run.name in text
        assert re.sub(r"\s+", " ", run.title) in text


def test_figure_links_other_than_http_or_anchors_are_dropped():
    """The report has no scripts: a javascript: link an artist carries is not kept; the
    SVG's own references (glyphs, embedded rasters) and web links are."""
    import matplotlib.pyplot as plt

    from workbench.app.report.collect import figure_svg

    fig, ax = plt.subplots()
    (line,) = ax.plot([0, 1], [0, 1])
    line.set_url("javascript:alert(1)")
    ax.text(0.5, 0.5, "x").set_url("https://example.org/a?b=1&c=2")
    ax.imshow([[0, 1], [1, 0]], extent=(0, 1, 0, 1))
    svg = figure_svg(fig, salt="t")
    plt.close(fig)
    assert "javascript" not in svg
    assert "https://example.org/a?b=1&amp;c=2" in svg or "https://example.org/a?b=1&c=2" in svg
    assert "data:image/png" in svg and 'xlink:href="#' in svg
