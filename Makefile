# Set-up and the two entry points named at the top of README.md.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast bench bench-smoke browser postgres clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

# Main job on the embedded default (simulated rig): 1-20 Vpp sweep at 400 Hz, 5 Nm.
demo: $(STAMP)
	$(VENV)/bin/labjoint simulate --sweep 1,2,4,8,12,16,20 --frequency 400 --torque 5 --out data/demo

# Headless Chromium from Debian for the web-page tests (no browser download by a test tool).
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq chromium chromium-driver >/dev/null; \
	  else sudo apt-get update -qq && sudo apt-get install -y -qq chromium chromium-driver >/dev/null; fi; }

# PostgreSQL from Debian for the shared-catalog tests: they start a throwaway server
# (tests/pg_server.py) with initdb/pg_ctl from /usr/lib/postgresql/<major>/bin; as root
# it runs as the package's "postgres" user, since initdb refuses root.
postgres:
	@ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || command -v initdb >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq postgresql >/dev/null; \
	  else sudo apt-get update -qq && sudo apt-get install -y -qq postgresql >/dev/null; fi; }

# The whole suite, slow end-to-end checks and every benchmark's smoke run
# (tests/test_benchmarks_smoke.py) included: what .ci/run runs.
test: $(STAMP) browser postgres
	$(PY) -m pytest -n 2 -q

# The suite without the `slow` marker group (a quick check while working; CI runs all).
test-fast: $(STAMP) browser postgres
	$(PY) -m pytest -n 2 -q -m "not slow"

# Every benchmark at full size; figures are ratios, with the load average before/after.
bench: $(STAMP)
	$(PY) -m benchmarks.run_all --json bench-results.json

# Every benchmark at tiny sizes (seconds each): they still run; no figure is judged.
bench-smoke: $(STAMP) browser
	$(PY) -m benchmarks.run_all --smoke

clean:
	rm -rf $(VENV) data .pytest_cache
