# Two commands do everything on a fresh machine with Python >= 3.11 and make:
#   make run    set up, then run the default scenario (plant, controller and recorder as
#               separate processes over Zenoh, in real time) and review it
#   make test   set up, then lint, type-check, build the docs and pass the tests
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= runs/default

.PHONY: setup run test test-quick lint typecheck docs pytest bench bench-speed bench-studies al2019-docs golden clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	# ROSCO's compiled controller (kind = "rosco"): the wheel's libdiscon only, without the
	# toolbox's dependencies (--no-deps keeps the install small).
	$(BIN)/python -m pip install --quiet --no-deps 'rosco==2.10.*'
	# Compile the numba kernels once (a few minutes on a fresh clone; cached in __pycache__),
	# so that no run, peer process or test starts late compiling them.
	$(BIN)/python -m hil.warmup
	touch $(STAMP)

run: setup
	$(BIN)/fowt run default --out $(OUT)

lint: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	# the layering rules (import-linter contracts in pyproject.toml)
	$(BIN)/lint-imports

typecheck: setup
	$(BIN)/mypy

# The documentation site; --strict turns every broken link or missing page into an error.
docs: setup
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir build/site

pytest: setup
	$(BIN)/python -m pytest

test: lint typecheck docs pytest

# The quick check while working (under 5 min on two cores, against about 35 min for `make
# test`): lint, type-check and the unit tests of the message schemas, CAN codec, scenario
# input, sensors, waves, aerodynamics, estimators and review, none launching a process.
# `make test` (and CI, .ci/run) still runs everything.
QUICK_TESTS ?= tests/test_bus_schemas.py tests/test_can_codec.py tests/test_can_db.py \
	tests/test_kpi_stats.py tests/test_review_kpi.py tests/test_review_plots.py \
	tests/test_review_stream.py tests/test_review_input.py tests/test_scenario_input.py \
	tests/test_sensor_channels.py tests/test_waves.py tests/test_plant_aero.py \
	tests/test_estimators.py
test-quick: lint typecheck
	$(BIN)/python -m pytest -m "not e2e" $(QUICK_TESTS)

# Regenerate the golden in-process KPIs (tests/test_golden_inprocess.py) after a deliberate
# change of what a run computes; `--check` instead only lists what would change.
golden: setup
	$(BIN)/python tools/golden_inprocess.py

RTPRIO ?= 20

# Every benchmark whose result the documentation cites (docs/benchmarks.md lists them all;
# tests/test_docs.py checks that each script a page names is run here). bench-speed: the
# bench's own speed and timing (about 3 h); bench-studies: the seeds' tables rerun (hours).
bench: bench-speed bench-studies
	$(BIN)/python bench/report.py

bench-speed: setup
	$(BIN)/python bench/realtime_latency.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/realtime_watchdog.py --runs 10 --duration 600 --hogs 2
	$(BIN)/python bench/lockstep_speed.py
	$(BIN)/python bench/lockstep_speed.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/inprocess_speed.py
	$(BIN)/python bench/runlog_encoding.py
	$(BIN)/python bench/whole_command_speed.py
	$(BIN)/python bench/startup_floor.py
	$(BIN)/python bench/soak_memory.py --soak
	$(BIN)/python bench/review_speed.py
	$(BIN)/python bench/plot_speed.py
	$(BIN)/python bench/review_memory.py
	$(BIN)/python bench/advanced_controller.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/soak.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/plant_wait_signal.py
	$(BIN)/python bench/campaign.py
	$(BIN)/python bench/campaign_run_speed.py
	$(BIN)/python bench/rosco.py --realtime-priority $(RTPRIO)
	$(BIN)/python bench/controller_compute.py
	$(BIN)/python bench/controller_compile.py
	$(BIN)/python bench/plant_compile_time.py
	$(BIN)/python bench/loop_compile_time.py
	$(BIN)/python bench/step_floating_speed.py
	$(BIN)/python bench/loop_profile.py plant
	$(BIN)/python bench/loop_profile.py parts
	$(BIN)/python bench/loop_profile.py kernel
	$(BIN)/python bench/loop_profile.py loop-only
	$(BIN)/python bench/loop_profile.py profile
	$(BIN)/python bench/can_soak.py --duration 600 --realtime-priority $(RTPRIO)
	$(BIN)/python bench/recording_completeness.py --hogs 2
	$(BIN)/python bench/recorder_kill_loss.py --hogs 2
	$(BIN)/python bench/auth_cost.py --count 20000 --duration 20 --rounds 4
	$(BIN)/python bench/session_auth_cost.py --links 20 --count 2000 --rounds 4
	$(BIN)/python bench/live_view_cost.py --duration 20 --rounds 3
	$(BIN)/python bench/live_view_cost.py --duration 20 --rounds 3 --hogs 2
	$(BIN)/python bench/peak_shaving_surge.py
	$(BIN)/python bench/bus_congestion.py
	$(BIN)/python bench/multihost_transport.py --runs 6
	$(BIN)/python bench/multihost_transport.py --runs 12 --only lowlatency

bench-studies: setup
	$(BIN)/python bench/below_rated_kpis.py
	$(BIN)/python bench/disannio_lqri.py
	$(BIN)/python bench/forecast_grid.py
	$(BIN)/python bench/settling.py
	$(BIN)/python bench/rosco_peer.py
	$(BIN)/python bench/modes_vs_openfast.py
	# the OC4 deck's hydrodynamics are computed with capytaine (the optional [hydro] extra)
	$(BIN)/python -m pip install --quiet -e '.[hydro]'
	$(BIN)/python bench/openfast_import_periods.py
	$(BIN)/python bench/free_decay.py
	$(BIN)/python bench/christiansen_case.py
	$(BIN)/python bench/hexicon.py
	$(BIN)/python bench/hexicon_identify.py
	$(BIN)/python bench/casanovas_table52.py --table31-only
	$(BIN)/python bench/casanovas_table52.py --seeds 3 --duration 450 --settle 160 --forecast
	$(BIN)/python bench/casanovas_table52.py --sensitivity --duration 300 --settle 100
	$(BIN)/python bench/trimmed_start.py
	$(BIN)/python bench/trimmed_start.py --table
	$(BIN)/python bench/trimmed_start.py --noise --kinds baseline,lqri_ff --winds 15
	$(BIN)/python bench/tsr_opt_sensitivity.py
	$(BIN)/python bench/casanovas_forecast_vaf.py
	$(BIN)/python bench/iea15_schedule.py
	$(BIN)/python bench/christiansen_seeds.py --pairs 10 --published --workers 2
	$(BIN)/python bench/christiansen_seeds.py --pairs 10 --decoupled --reuse bench/results/christiansen_seeds_statistics.json
	$(BIN)/python bench/christiansen_damping_map.py
	$(BIN)/python bench/hexicon_identify_amplitude.py --workers 4
	$(BIN)/python bench/hexicon_yaw_coast_down.py

# The al-2019 study's figures (docs/studies/al-2019.md): the below-rated table
# (bench/results/below_rated_kpis.json) and the load-case campaign's aggregates and per-run
# tables (docs/al2019-reduced/): against the baseline (210 runs), and the wave FF against
# lqri (168 runs). The page's tables quote these files.
al2019-docs: setup
	$(BIN)/python bench/below_rated_kpis.py
	$(BIN)/fowt campaign al2019-iea15mw --record none --no-html --out runs/al2019
	cp runs/al2019/aggregates.json docs/al2019-reduced/aggregates-vs-baseline.json
	cp runs/al2019/results.csv docs/al2019-reduced/results-baseline-view.csv
	# the lqri view: its 126 shared runs are taken from the first (--resume, same hashes)
	$(BIN)/fowt campaign al2019-iea15mw --baseline lqri --controllers lqri_ff_bp,lqri_ff_mp \
		--record none --no-html --resume --out runs/al2019
	cp runs/al2019/aggregates.json docs/al2019-reduced/aggregates-vs-lqri.json
	cp runs/al2019/results.csv docs/al2019-reduced/results-lqri-view.csv

clean:
	rm -rf $(VENV) runs .pytest_cache .mypy_cache .ruff_cache
