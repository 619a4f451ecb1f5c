# knitc: developer commands. Everything runs inside ./.venv, which `make` creates itself;
# nothing needs to be installed by hand beyond python3 (>= 3.11) with venv and pip.
#
#   make run        create .venv, install knitc into it, check and dump examples/sweater.knit
#   make test       install knitc + test tools into .venv, run the test suite
#   make lint       ruff check
#   make fmt-check  ruff format --check (make fmt applies it)
#   make clean      remove build artifacts and caches (make distclean also removes .venv)

VENV    := .venv
BIN     := $(VENV)/bin
PIP     := $(BIN)/pip
# Prefer python3.11 if it is on PATH; override with `make PYTHON=/path/to/python`.
PYTHON  ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
EXAMPLE := examples/sweater.knit
SRC     := compiler tests

.DEFAULT_GOAL := help
.PHONY: help venv install run test lint fmt fmt-check clean distclean

help:
	@echo "make run        install knitc into .venv and run the front end on $(EXAMPLE)"
	@echo "make test       install knitc and its test extra into .venv, run pytest"
	@echo "make lint       ruff check $(SRC)"
	@echo "make fmt-check  ruff format --check $(SRC)   (make fmt: reformat)"
	@echo "make venv       create .venv if missing;  make install: (re)install knitc into it"
	@echo "make clean      remove build artifacts and caches;  make distclean: also .venv"

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
	$(BIN)/knitc --emit trace -o $(EXAMPLE:.knit=.trace.json) $(EXAMPLE)
	@echo "make run: '$(EXAMPLE)' checks clean and is lowered to its stitch graph and traced" \
	  "yarn ($(EXAMPLE:.knit=.trace.json)); Knitout generation is not implemented yet."

test: venv
	@rm -rf build
	$(PIP) install -q ".[test]"
	$(BIN)/python -m pytest

# ruff comes with the test extra; install just ruff when only lint is asked for.
$(BIN)/ruff: | $(BIN)/python
	$(PIP) install -q ruff

lint: $(BIN)/ruff
	$(BIN)/ruff check $(SRC)

fmt-check: $(BIN)/ruff
	$(BIN)/ruff format --check $(SRC)

fmt: $(BIN)/ruff
	$(BIN)/ruff format $(SRC)
	$(BIN)/ruff check --fix $(SRC)

clean:
	rm -rf build dist compiler/*.egg-info *.egg-info .pytest_cache .ruff_cache .hypothesis bench/tmp
	find . -path ./$(VENV) -prune -o -type d -name __pycache__ -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV)
