# All targets use the project's own virtual environment (.venv), created by `make install`.
PY ?= .venv/bin/python
export NUMBA_CACHE_DIR ?= $(CURDIR)/.venv/numba-cache

.PHONY: install test maps bench clean

install: .venv/installed

.venv/installed: pyproject.toml
	python3 -m venv .venv
	.venv/bin/pip install -q --upgrade pip
	.venv/bin/pip install -q -e '.[test]'
	touch $@

test: install
	$(PY) -m pytest -q

maps: install
	$(PY) -m placement.cli.main maps build --robot pr2 --spec maps/pr2.yaml --out maps/pr2

bench: install
	$(PY) tools/bench.py

clean:
	rm -rf .venv build *.egg-info .pytest_cache
