# Quick start on a fresh machine: `make demo` and `make test`.
VENV    ?= .venv
PY      := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
RESULTS ?= results

.PHONY: install kinder demo test test-all bench bench-quick domains clean

$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

## kinder: KinDER's kinematic-2D environments (docs/kinder.md), without the packages that would change .[test]'s versions
kinder: $(STAMP)
	$(PY) -m pip install -q -e '.[test,kinder]'
	$(PY) -m pip install -q --no-deps -r requirements-kinder.txt

## demo: the whole pipeline on defaults, outputs in results/
demo: $(STAMP)
	$(PY) examples/demo.py --out $(RESULTS)

## test: the fast test suite (slow tests: make test-all)
test: $(STAMP)
	$(PY) -m pytest -q

test-all: $(STAMP)
	$(PY) -m pytest -q -m ''

## bench: every benchmark in benchmarks/ (minutes); bench-quick: each on a small workload (seconds, CI)
bench: $(STAMP)
	$(PY) benchmarks/run_all.py

bench-quick: $(STAMP)
	$(PY) benchmarks/run_all.py --quick

clean:
	rm -rf $(RESULTS) .pytest_cache
