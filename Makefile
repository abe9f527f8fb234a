# Two commands do everything on a fresh machine with Python >= 3.11 and make:
#   make run    set up, then run the default scenario (plant, controller and recorder as
#               separate processes over Zenoh, in real time) and review it
#   make test   set up, then lint, type-check, build the docs and pass the tests
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= runs/default

.PHONY: setup run test lint typecheck docs pytest bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	# ROSCO's compiled controller (kind = "rosco"): the wheel's libdiscon only, without the
	# toolbox's dependencies (--no-deps keeps the install small).
	$(BIN)/python -m pip install --quiet --no-deps 'rosco==2.10.*'
	# Compile the numba kernels once (about 1 min on a fresh clone; cached in __pycache__),
	# so that no run, peer process or test starts late compiling them.
	$(BIN)/python -m hil.warmup
	touch $(STAMP)

run: setup
	$(BIN)/fowt run default --out $(OUT)

lint: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: setup
	$(BIN)/mypy

# The documentation site; --strict turns every broken link or missing page into an error.
docs: setup
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir build/site

pytest: setup
	$(BIN)/python -m pytest

test: lint typecheck docs pytest

RTPRIO ?= 20

bench: setup
	$(BIN)/python bench/realtime_latency.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/lockstep_speed.py
	$(BIN)/python bench/inprocess_speed.py
	$(BIN)/python bench/whole_command_speed.py
	$(BIN)/python bench/review_speed.py
	$(BIN)/python bench/advanced_controller.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/soak.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/plant_wait_signal.py
	$(BIN)/python bench/campaign.py
	$(BIN)/python bench/rosco.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/controller_compute.py
	$(BIN)/python bench/plant_cycle_speed.py
	$(BIN)/python bench/can_soak.py --duration 600 --realtime-priority $(RTPRIO)
	$(BIN)/python bench/recording_completeness.py --hogs 2
	$(BIN)/python bench/recorder_kill_loss.py --hogs 2
	$(BIN)/python bench/auth_cost.py
	$(BIN)/python bench/below_rated_kpis.py
	$(BIN)/python bench/disannio_lqri.py
	$(BIN)/python bench/report.py

clean:
	rm -rf $(VENV) runs .pytest_cache .mypy_cache .ruff_cache
