# The README's commands live here. Every target sets up the virtual environment first,
# so each one works on a fresh clone.
# The interpreter that creates .venv: the first of Python 3.11, 3.12, 3.13 found on PATH
# (override with `make PYTHON=python3.12 ...`).
PYTHON ?= $(firstword $(foreach p,python3.11 python3.12 python3.13,$(if $(shell command -v $(p) 2>/dev/null),$(p))))
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

# One BLAS thread: the workbench's matrices are small (at most a few hundred rows), and on
# the 2 shared cores multi-threaded OpenBLAS made an 84x86 SVD take 30 ms to 1.4 s instead
# of 1 ms (measured). Override on the command line if your matrices are large.
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: setup run report report-quick test test-deps test-all lint bench clean

$(STAMP): pyproject.toml Makefile
	@test -n "$(PYTHON)" && command -v $(PYTHON) >/dev/null 2>&1 || { echo "error: no Python 3.11, 3.12 or 3.13 found (python3.11, python3.12, python3.13 on PATH; or make PYTHON=...)"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,sweep]'
	@touch $(STAMP)

setup: $(STAMP)

## The main job: the report of every problem, HTML and PDF, in reports/out/
## (report.html, report.pdf).
report: $(STAMP)
	$(BIN)/workbench report

## The same in quick mode (reports/out/report-quick.html, report-quick.pdf).
report-quick: $(STAMP)
	$(BIN)/workbench report --quick

## Every problem in quick mode, results printed to the terminal.
run: $(STAMP)
	$(BIN)/workbench run all --quick

## Test set-up: headless Chromium (report screenshot test), poppler-utils (PDF checks) and
## the DejaVu fonts (the report's text and MathML font), from the distribution's packages,
## installed only when missing.
test-deps:
	@if command -v chromium >/dev/null 2>&1 && command -v pdftoppm >/dev/null 2>&1 \
	    && command -v pdftotext >/dev/null 2>&1 \
	    && [ -f /usr/share/fonts/truetype/dejavu/DejaVuMathTeXGyre.ttf ]; then :; else \
	  command -v apt-get >/dev/null 2>&1 || { echo "error: the report tests need chromium and poppler-utils, and apt-get is not available to install them"; exit 1; }; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
	  echo "installing chromium, poppler-utils and the DejaVu fonts (text and math) with apt-get"; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq \
	    chromium poppler-utils fonts-dejavu-core fonts-dejavu-extra >/dev/null || { echo "error: apt-get could not install chromium and poppler-utils"; exit 1; }; \
	fi

## The tests (slow ones excluded; `make test-all` runs them too).
test: $(STAMP) test-deps
	$(BIN)/python -m pytest -q

test-all: $(STAMP) test-deps
	$(BIN)/python -m pytest -q -m ''

lint: $(STAMP)
	$(BIN)/ruff check workbench models problems tests benchmarks

bench: $(STAMP)
	$(BIN)/workbench bench

clean:
	rm -rf $(VENV) geometric_pendulum_workbench.egg-info reports/out
