# The two commands a user needs: `make reproduce` and `make test`. The first run of either creates
# .venv and installs the project with the pinned versions of constraints.txt; `make test` adds the
# test dependencies (pytest, the GLSL compiler).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
INSTALLED := $(VENV)/.installed
TEST_INSTALLED := $(VENV)/.installed-test
PIP := $(BIN)/pip install --quiet --disable-pip-version-check -c constraints.txt
CONFIG ?= configs/paper.toml
SET ?=

export JAX_ENABLE_X64 := 1
export JAX_PLATFORMS := cpu

.PHONY: reproduce test bench refit clean keys graph

$(INSTALLED): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PIP) -e .
	touch $(INSTALLED)

$(TEST_INSTALLED): $(INSTALLED)
	$(PIP) -e ".[test]"
	touch $(TEST_INSTALLED)

reproduce: $(INSTALLED)
	$(BIN)/pipeline reproduce

refit: $(INSTALLED)
	$(BIN)/pipeline refit --config $(CONFIG) $(foreach s,$(SET),--set $(s))

test: $(TEST_INSTALLED)
	$(BIN)/python -m pytest -q

bench: $(TEST_INSTALLED)
	$(BIN)/python bench/bench.py

keys: $(INSTALLED)
	$(BIN)/pipeline keys

graph: $(INSTALLED)
	$(BIN)/pipeline graph

clean:
	rm -rf .cache
	find outputs -mindepth 1 -maxdepth 1 ! -name .gitkeep -exec rm -rf {} +
