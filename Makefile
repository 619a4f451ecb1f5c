# knitc: developer commands. Everything runs inside ./.venv, which `make` creates itself;
# nothing needs to be installed by hand beyond python3 (>= 3.11) with venv and pip.
#
#   make run        create .venv, install knitc into it, compile examples/sweater.knit to Knitout
#   make test       install knitc + test tools into .venv, run the test suite (deterministic)
#   make explore    the test suite with fresh random hypothesis examples
#   make fuzz       coverage-guided fuzzing of every target, FUZZ_TIME s each (default 60;
#                   CI runs it after the tests); make fuzz-long: 30 minutes each
#   make coverage   the test suite under coverage.py; fails below 95 % of compiler/knitc's lines
#   make lint       ruff check, ruff format --check, mypy (what CI runs after the tests)
#   make fmt-check  ruff format --check (make fmt applies it)
#   make clean      remove build artifacts and caches (make distclean also removes .venv)
#   make oracle-venv  create .venv-oracle, the independent Knitout oracle's own venv
#                     (make test does it; make oracle-clean removes it)
#   make editors-deps npm ci in editors/vscode: the VS Code extension's grammar test tools
#                     (make test does it when the lock file changed; skipped without npm)

VENV    := .venv
BIN     := $(VENV)/bin
PIP     := $(BIN)/pip
# Prefer python3.11 if it is on PATH; override with `make PYTHON=/path/to/python`.
PYTHON  ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
EXAMPLE := examples/sweater.knit
SRC     := compiler tests

# The independent Knitout oracle (knitout-interpreter + virtual-knitting-machine, see
# shared/research/peers-and-oracles.md) gets its own venv and is never a knitc dependency.
# tests/oracle.py runs tests/oracle_runner.py with its python. Python 3.12 runs it about 3x
# faster than 3.11, so 3.12 is preferred: python3.12 on PATH if it runs (a pyenv shim may not),
# else pyenv's newest 3.12, else python3.11. Override with `make ORACLE_BASE_PYTHON=...`.
ORACLE_VENV := .venv-oracle
ORACLE_PINS := knitout-interpreter==0.1.8 virtual-knitting-machine==0.0.31 knit-graphs==0.1.4
ORACLE_BASE_PYTHON ?= $(shell \
  pyroot=$$(pyenv root 2>/dev/null || echo "$$HOME/.pyenv"); \
  for p in python3.12 $$(ls -d "$$pyroot"/versions/3.12.*/bin/python3.12 2>/dev/null | sort -V | tail -n 1) python3.11; do \
    "$$p" -c 'import sys; sys.exit(sys.version_info[:2] not in ((3, 12), (3, 11)))' >/dev/null 2>&1 \
      && { command -v "$$p"; break; }; \
  done)

.DEFAULT_GOAL := help
.PHONY: help venv install run test explore fuzz fuzz-long coverage lint fmt fmt-check clean distclean oracle-venv oracle-clean bench editors-deps

help:
	@echo "make run        install knitc into .venv and compile $(EXAMPLE) to Knitout"
	@echo "make test       install knitc and its test extra into .venv, run pytest"
	@echo "make explore    the test suite with fresh random hypothesis examples each run"
	@echo "make fuzz       fuzz every target for FUZZ_TIME seconds (60);  make fuzz-long: 30 min each"
	@echo "make coverage   the suite under coverage: line coverage of compiler/knitc, at least 95 %"
	@echo "make lint       ruff check, ruff format --check and mypy on $(SRC)"
	@echo "make fmt-check  ruff format --check $(SRC)   (make fmt: reformat)"
	@echo "make venv       create .venv if missing;  make install: (re)install knitc into it"
	@echo "make clean      remove build artifacts and caches;  make distclean: also .venv"
	@echo "make oracle-venv  create $(ORACLE_VENV) (the Knitout oracle);  make oracle-clean: remove it"
	@echo "make editors-deps npm ci in editors/vscode (the grammar tests' tools), when its lock file changed"

# The venv is created only if missing (its python is the stamp).
venv: $(BIN)/python

$(BIN)/python:
	@test -n "$(PYTHON)" || { echo "error: no python3 found on PATH" >&2; exit 1; }
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || { \
	  echo "error: knitc needs Python >= 3.11, but $(PYTHON) is $$($(PYTHON) -V 2>&1)" >&2; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip

# A real, non-editable install, re-run every time so source changes are picked up. The
# in-tree build/ directory is removed first: setuptools never prunes it, so a module
# deleted from the source would otherwise live on in the installed package.
install: venv
	@rm -rf build
	$(PIP) install -q .

run: install
	$(BIN)/knitc check $(EXAMPLE)
	$(BIN)/knitc $(EXAMPLE) -o $(EXAMPLE:.knit=.k)
	@echo "make run: compiled '$(EXAMPLE)' to Knitout ($(EXAMPLE:.knit=.k)); see README for" \
	  "what the back end supports so far."

test: venv oracle-venv editors-deps
	@rm -rf build
	$(PIP) install -q ".[test]"
	$(BIN)/python -m pytest

# `make test` draws the same hypothesis examples on every run (tests/conftest.py); this runs
# the suite with new random ones, keeping what fails in .hypothesis/ to replay.
explore: venv oracle-venv
	@rm -rf build
	$(PIP) install -q ".[test]"
	KNITC_HYPOTHESIS=explore $(BIN)/python -m pytest

# Line coverage of compiler/knitc by the test suite; fails below 95 %.
coverage: venv oracle-venv
	@rm -rf build
	$(PIP) install -q -e ".[test]"
	@rm -f .coverage .coverage.*
	$(BIN)/python -m coverage run -m pytest -p no:cacheprovider
	$(BIN)/python -m coverage combine -q
	$(BIN)/python -m coverage report --skip-covered --fail-under=95

# Fuzzing (tests/fuzz/run.py): each target under libFuzzer with fresh seeds, a crash, hang or
# blow-up prints its reproducer and fails; then a sample of the compiled designs runs on the
# independent machine. FUZZ_ARGS passes more (targets, --seed N, --timeout S).
FUZZ_TIME ?= 60
fuzz: venv oracle-venv
	@rm -rf build
	$(PIP) install -q ".[test,fuzz]"
	$(BIN)/python tests/fuzz/run.py --time $(FUZZ_TIME) $(FUZZ_ARGS)

fuzz-long:
	$(MAKE) fuzz FUZZ_TIME=1800

# Speed and memory of every example and of a scaling series (bench/results.json).
bench: install oracle-venv
	$(BIN)/python bench/run.py

# The linters are the test extra's pinned versions (pyproject.toml), so a developer's
# `make lint` and CI's agree; the stamp re-installs them when the pins change.
$(VENV)/.tools: pyproject.toml | $(BIN)/python
	$(PIP) install -q $$($(BIN)/python -c 'import tomllib; print(" ".join(tomllib.load(open("pyproject.toml", "rb"))["project"]["optional-dependencies"]["test"]))')
	@touch $@

lint: $(VENV)/.tools
	$(BIN)/ruff check $(SRC)
	$(BIN)/ruff format --check $(SRC)
	$(BIN)/mypy

fmt-check: $(VENV)/.tools
	$(BIN)/ruff format --check $(SRC)

fmt: $(VENV)/.tools
	$(BIN)/ruff format $(SRC)
	$(BIN)/ruff check --fix $(SRC)

clean:
	rm -rf build dist compiler/*.egg-info *.egg-info .pytest_cache .ruff_cache .hypothesis bench/tmp
	find . -path ./$(VENV) -prune -o -type d -name __pycache__ -exec rm -rf {} +

distclean: clean oracle-clean
	rm -rf $(VENV)

# Rebuilt only when missing or when ORACLE_PINS changed (the pins are its stamp). The venv gets
# its own .gitignore so that git never sees it.
oracle-venv:
	@if [ -x $(ORACLE_VENV)/bin/python ] && [ "$$(cat $(ORACLE_VENV)/.pins 2>/dev/null)" = "$(ORACLE_PINS)" ]; then \
	  exit 0; \
	fi; \
	py="$(ORACLE_BASE_PYTHON)"; \
	if [ -z "$$py" ]; then echo "error: oracle-venv needs python3.12 or python3.11" >&2; exit 1; fi; \
	echo "creating $(ORACLE_VENV) with $$py ($$("$$py" -V 2>&1)): $(ORACLE_PINS)"; \
	rm -rf $(ORACLE_VENV) && "$$py" -m venv $(ORACLE_VENV) && echo '*' > $(ORACLE_VENV)/.gitignore && \
	$(ORACLE_VENV)/bin/pip install -q --disable-pip-version-check $(ORACLE_PINS) && \
	echo "$(ORACLE_PINS)" > $(ORACLE_VENV)/.pins

oracle-clean:
	rm -rf $(ORACLE_VENV)

# The VS Code extension's npm packages (editors/vscode), which tests/test_editors.py runs the
# grammar tests with. npm writes node_modules/.package-lock.json on every install, so it is the
# stamp: `npm ci` runs again only when package-lock.json is newer. Without npm, or if npm ci
# fails, this prints a notice and succeeds; the tests then skip (or, under CI, fail saying so).
editors-deps: editors/vscode/node_modules/.package-lock.json
	@:

editors/vscode/node_modules/.package-lock.json: editors/vscode/package-lock.json
	@if command -v npm >/dev/null 2>&1; then \
	  echo "npm ci in editors/vscode"; \
	  cd editors/vscode && { npm ci --no-audit --no-fund --loglevel=error >/dev/null && touch node_modules/.package-lock.json \
	    || echo "make editors-deps: npm ci failed in editors/vscode, so the editor grammar tests cannot run"; }; \
	else \
	  echo "make editors-deps: npm is not on PATH, so the editor grammar tests (tests/test_editors.py) cannot run"; \
	fi
