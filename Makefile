# robolab_ms: two commands for a new machine.
#   make demo   set up (.venv, dependencies, rendering) and run a small evaluation
#   make test   set up and run the test suite without the slow end-to-end tests (minutes)
#   make test-slow / make test-all   only the slow tests / every test (CI runs test, then test-slow)
#   make lerobot-env   the separate Python 3.12 environment for LeRobot policy servers (docs/policies.md)
# Both are idempotent: a second run only re-installs robolab_ms when its sources changed.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
DEPS_STAMP := $(VENV)/.deps-installed
PKG_STAMP := $(VENV)/.robolab-installed
SOURCES := $(shell find robolab_ms eval analysis assets scene_builders task_specs -type f \
             -not -path '*/__pycache__/*' 2>/dev/null) pyproject.toml setup.py

.PHONY: demo test test-slow test-all lint setup render-check assets lerobot-env clean

demo: setup
	$(BIN)/robolab eval --policy random --task BananaInBowl --episodes 2 --out results/demo

test: setup
	$(BIN)/pytest -q -m "not slow"

test-slow: setup
	$(BIN)/pytest -q -m slow

test-all: setup
	$(BIN)/pytest -q

# ruff: the rule set and line length are in pyproject.toml
lint: $(DEPS_STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

setup: $(PKG_STAMP) render-check assets

# requirements.lock pins the dependencies and the extras' packages (ray, vla-eval): setup installs them all.
$(DEPS_STAMP): requirements.lock
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade "pip>=24"
	$(BIN)/python -m pip install --quiet -r requirements.lock
	@touch $@

# A regular (not editable) install: the code is used exactly as a user gets it, start-up hook included.
# ROBOLAB_MS_LINK_CHECKOUT=1 records this checkout in the package: content (task_specs/, scene_builders/, assets/)
# is then read from here, so edits to it take effect without re-installing (see setup.py).
$(PKG_STAMP): $(DEPS_STAMP) $(SOURCES)
	ROBOLAB_MS_LINK_CHECKOUT=1 $(BIN)/python -m pip install --quiet --no-deps --no-build-isolation --force-reinstall .
	@rm -rf build *.egg-info
	$(BIN)/python -m pip check
	@touch $@

render-check: $(PKG_STAMP)
	@scripts/setup_vulkan.sh $(BIN)/python

# HDR backgrounds from npm (@pmndrs/assets), decoded into .venv; see scripts/setup_assets.sh.
assets: $(PKG_STAMP)
	@scripts/setup_assets.sh $(BIN)/python

# LeRobot 0.5+ needs Python 3.12 and numpy 2: its own environment, pinned in requirements-lerobot.lock, kept in
# robolab_ms's cache folder (shared by every checkout on the machine) and linked here as .venv-lerobot.
lerobot-env:
	@scripts/setup_lerobot_env.sh

clean:
	rm -rf $(VENV) build *.egg-info results
	rm -f .venv-lerobot  # the link only: the environment itself is shared (see lerobot-env)
