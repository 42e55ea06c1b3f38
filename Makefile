# Two commands do all the set-up: `make play` and `make test` each create .venv first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: play test lint docs bench experiment clean

play: $(STAMP)
	$(BIN)/careful play

# Lint and types first: a failure there is quicker to read than the tests it would break.
# Two processes; a file's tests stay on one (--dist loadfile), so a file's fixtures (a server, a
# tmux session, a cluster) are made once and its tests never race each other.
test: lint
	$(BIN)/python -m pytest -n 2 --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check irl_core careful_tui bench
	$(BIN)/mypy
	$(BIN)/vulture

# The manual, in site/; --strict fails on a broken link or anchor.
docs: $(STAMP)
	$(BIN)/mkdocs build --strict

bench: $(STAMP)
	$(BIN)/python -m bench

experiment: $(STAMP)
	$(BIN)/careful experiment --out experiment

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "careful needs Python 3.11 or newer (set PYTHON=python3.11)")'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[all,test]'
	touch $(STAMP)

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache site
