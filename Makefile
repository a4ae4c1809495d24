# The README's commands live here. Every target sets up the virtual environment first,
# so each one works on a fresh clone.

# The Pythons that pyproject.toml declares (requires-python >=3.11,<3.14), oldest first.
PYTHONS := 3.11 3.12 3.13
NEWEST  := $(lastword $(PYTHONS))

# The first Python of the versions $(1) that runs, as the path of its own executable:
# python3.X on PATH, else pyenv's own install of it. A pyenv shim of a version pyenv has not
# selected is on PATH but does not run ("pyenv: python3.13: command not found"): it is
# passed over.
runnable = $(shell for v in $(1); do for c in python$$v $$(ls -d "$$(pyenv root 2>/dev/null)"/versions/$$v.*/bin/python$$v 2>/dev/null | sort -rV); do "$$c" -c 'import sys; print(sys.executable)' 2>/dev/null && exit 0; done; done)

# The interpreter that creates .venv: the first of Python 3.11, 3.12, 3.13 that runs
# (override with `make PYTHON=python3.12 ...`; looked up only when a target needs it, once).
PYTHON ?= $(eval PYTHON := $(call runnable,$(PYTHONS)))$(PYTHON)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

# The fast subset of the tests that `make test-newest` runs on the newest declared Python,
# in its own virtual environment: the engine's mathematics room by room, where numpy's and
# scipy's versions show (rounding, SVDs, Riccati and eigen solvers, continuation), and the
# public API (about a minute on 2 shared cores; the whole suite takes over ten).
NEWEST_PYTHON ?= $(eval NEWEST_PYTHON := $(call runnable,$(NEWEST)))$(NEWEST_PYTHON)
NEWEST_VENV   := .venv-$(NEWEST)
FAST_TESTS    := tests/test_manifolds.py tests/test_model.py tests/test_evaluator.py \
                 tests/test_validate.py tests/test_status.py tests/test_mechanics_models.py \
                 tests/test_simulate.py tests/test_integrators.py tests/test_linearize.py \
                 tests/test_eigen.py tests/test_lqr.py tests/test_controllability.py \
                 tests/test_symbolic.py tests/test_equilibria.py tests/test_continuation.py \
                 tests/test_relative_equilibria.py tests/test_invariant_manifolds.py \
                 tests/test_poincare.py tests/extremes/test_extreme_properties.py \
                 tests/test_api_paths.py tests/test_pythons.py tests/test_structure.py

# One BLAS thread: the workbench's matrices are small (at most a few hundred rows), and on
# the 2 shared cores multi-threaded OpenBLAS made an 84x86 SVD take 30 ms to 1.4 s instead
# of 1 ms (measured). Override on the command line if your matrices are large.
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: setup run report report-quick test test-deps test-all test-newest lint bench clean

# What a virtual environment was made with: its interpreter's version and real path (a
# venv's python resolves to the interpreter that made it). A venv made with another
# interpreter than the one asked for now (make PYTHON=...) is made again: its stamp target is
# then phony, so its recipe runs, and the recipe removes the old venv first.
py_id = $(if $(1),$(shell $(1) -c 'import os, sys; print(sys.version.split()[0], os.path.realpath(sys.executable))' 2>/dev/null))
ifneq ($(filter-out clean test-deps test-newest $(NEWEST_VENV)/.installed,$(or $(MAKECMDGOALS),all)),)
ifneq ($(call py_id,$(BIN)/python),$(call py_id,$(PYTHON)))
.PHONY: $(STAMP)
endif
endif
ifneq ($(filter $(NEWEST_VENV)/.installed,$(MAKECMDGOALS)),)
ifneq ($(call py_id,$(NEWEST_VENV)/bin/python),$(call py_id,$(NEWEST_PYTHON)))
.PHONY: $(NEWEST_VENV)/.installed
endif
endif

# $(call make-venv,DIR,PYTHON): a virtual environment in DIR with the package installed
# (editable, with its dev and sweep extras), made by PYTHON after checking that it runs and
# is a declared version; DIR/.installed records the interpreter.
define make-venv
	@test -n "$(2)" || { echo "error: no Python $(firstword $(PYTHONS)) to $(NEWEST) that runs (python3.X on PATH, or installed by pyenv); name one with make PYTHON=..."; exit 1; }
	@command -v $(2) >/dev/null 2>&1 || { echo "error: PYTHON=$(2) is not a command"; exit 1; }
	@$(2) -c '' >/dev/null 2>&1 || { echo "error: PYTHON=$(2) does not run (a pyenv shim of a version pyenv has not selected?); it says:"; $(2) -c '' 2>&1 | sed '/^$$/d; s/^/    /'; \
	  v=$$(basename $(2) | sed -n 's/^python\(3\.[0-9]*\)$$/\1/p'); case " $(PYTHONS) " in *" $$v "*) for c in $$(ls -d "$$(pyenv root 2>/dev/null)"/versions/$$v.*/bin/python$$v 2>/dev/null); do echo "pyenv's own interpreter runs: make PYTHON=$$c"; break; done;; esac; exit 1; }
	@$(2) -c 'import sys; sys.exit(sys.version_info[:2] not in [tuple(map(int, v.split("."))) for v in "$(PYTHONS)".split()])' || { echo "error: PYTHON=$(2) is Python $$($(2) -c 'import sys; print(sys.version.split()[0])'); the package declares $(PYTHONS)"; exit 1; }
	@want="$$($(2) -c 'import os, sys; print(sys.version.split()[0], os.path.realpath(sys.executable))')"; \
	have="$$($(1)/bin/python -c 'import os, sys; print(sys.version.split()[0], os.path.realpath(sys.executable))' 2>/dev/null)"; \
	if [ -e $(1) ] && [ "$$have" != "$$want" ]; then \
	  echo "$(1) was made with $${have:-a Python that no longer runs}; making it again with $$want"; rm -rf $(1); fi
	$(2) -m venv $(1)
	$(1)/bin/python -m pip install --quiet --upgrade pip
	$(1)/bin/python -m pip install --quiet -e '.[dev,sweep]'
	@$(2) -c 'import os, sys; print(sys.version.split()[0], os.path.realpath(sys.executable))' > $(1)/.installed
endef

$(STAMP): pyproject.toml Makefile
	$(call make-venv,$(VENV),$(PYTHON))

$(NEWEST_VENV)/.installed: pyproject.toml Makefile
	$(call make-venv,$(NEWEST_VENV),$(NEWEST_PYTHON))

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
## installed only when missing. `make test-deps` fails where they cannot be installed (no
## apt-get, or apt-get failing); `make test` then goes on, and the tests that need them are
## skipped with one line naming what to install (tests/conftest.py).
TEST_DEPS_STRICT ?= 1
test-deps:
	@if command -v chromium >/dev/null 2>&1 && command -v pdftoppm >/dev/null 2>&1 \
	    && command -v pdftotext >/dev/null 2>&1 \
	    && [ -f /usr/share/fonts/truetype/dejavu/DejaVuMathTeXGyre.ttf ]; then :; else \
	  cannot() { if [ "$(TEST_DEPS_STRICT)" = 1 ]; then echo "error: $$1"; exit 1; fi; \
	    case "$$1" in apt-get\ could*) echo "$$1; the tests that need them are skipped";; esac; \
	    exit 0; }; \
	  command -v apt-get >/dev/null 2>&1 || cannot "the report tests need chromium and poppler-utils, and apt-get is not available to install them"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
	  echo "installing chromium, poppler-utils and the DejaVu fonts (text and math) with apt-get"; \
	  log=$$(mktemp); { $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO \
	    apt-get install -y -qq chromium poppler-utils fonts-dejavu-core fonts-dejavu-extra; } \
	    >$$log 2>&1 || cannot "apt-get could not install chromium and poppler-utils (its output: $$log)"; \
	  rm -f $$log; \
	fi

## The tests (slow ones excluded; `make test-all` runs them too).
test: $(STAMP)
	@$(MAKE) --no-print-directory test-deps TEST_DEPS_STRICT=0
	$(BIN)/python -m pytest -q

test-all: $(STAMP)
	@$(MAKE) --no-print-directory test-deps TEST_DEPS_STRICT=0
	$(BIN)/python -m pytest -q -m ''

## The fast subset of the tests (FAST_TESTS) on the newest declared Python, in its own
## virtual environment (.venv-3.13); skipped, with a line saying so, where no such Python runs.
test-newest:
	@if [ -z "$(NEWEST_PYTHON)" ]; then \
	  echo "skipped: no Python $(NEWEST) runs here (python$(NEWEST) on PATH, or installed by pyenv), so the fast tests on the newest declared Python did not run"; \
	else $(MAKE) --no-print-directory $(NEWEST_VENV)/.installed NEWEST_PYTHON=$(NEWEST_PYTHON) \
	  && $(NEWEST_VENV)/bin/python -m pytest -q $(FAST_TESTS); fi

lint: $(STAMP)
	$(BIN)/ruff check workbench models problems tests benchmarks

bench: $(STAMP)
	$(BIN)/workbench bench

clean:
	rm -rf $(VENV) $(NEWEST_VENV) geometric_pendulum_workbench.egg-info reports/out
