# Set-up and the two entry points named at the top of README.md.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow test-all bench bench-smoke browser postgres clean

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

# The suite without the `slow` end-to-end group (under 10 minutes on 2 cores): the
# README's test command. .ci/run runs it, then the slow group (make test-slow).
test: $(STAMP) browser postgres
	$(PY) -m pytest -n 2 -q -m "not slow"

# The slow end-to-end group alone: structure and BERT loops, every benchmark's smoke run
# (tests/test_benchmarks_smoke.py).
test-slow: $(STAMP) browser postgres
	$(PY) -m pytest -n 2 -q -m slow

# Both groups in one pytest run.
test-all: $(STAMP) browser postgres
	$(PY) -m pytest -n 2 -q

# Every benchmark at full size; figures are ratios, with the load average before/after.
bench: $(STAMP)
	$(PY) -m benchmarks.run_all --json bench-results.json

# Every benchmark at tiny sizes (seconds each): they still run; no figure is judged.
bench-smoke: $(STAMP) browser
	$(PY) -m benchmarks.run_all --smoke

clean:
	rm -rf $(VENV) data .pytest_cache
