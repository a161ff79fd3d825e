# The two commands a user needs: `make reproduce` and `make test`. The first run of either creates
# .venv and installs the project with the pinned versions of constraints.txt.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
INSTALLED := $(VENV)/.installed
CONFIG ?= configs/paper.toml
SET ?=

export JAX_ENABLE_X64 := 1
export JAX_PLATFORMS := cpu

.PHONY: reproduce test bench refit clean keys

$(INSTALLED): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --disable-pip-version-check -c constraints.txt -e .
	touch $(INSTALLED)

reproduce: $(INSTALLED)
	$(BIN)/pipeline reproduce

refit: $(INSTALLED)
	$(BIN)/pipeline refit --config $(CONFIG) $(foreach s,$(SET),--set $(s))

test: $(INSTALLED)
	$(BIN)/python -m pytest -q

bench: $(INSTALLED)
	$(BIN)/python bench/bench.py

keys: $(INSTALLED)
	$(BIN)/pipeline keys

clean:
	rm -rf .cache
	find outputs -mindepth 1 -maxdepth 1 ! -name .gitkeep -exec rm -rf {} +
