# All targets use the project's own virtual environment (.venv), created by `make install`.
PY ?= .venv/bin/python
# The compiled kernels' cache: placement.kernels reads NUMBA_CACHE_DIR, else <venv>/numba-cache, so
# .venv/bin/placement finds what `make install` compiled; same place here. The benchmark tools start
# processes of their own: OpenMP waits passively there too (placement/process_env.py says why).
export NUMBA_CACHE_DIR ?= $(CURDIR)/.venv/numba-cache
export OMP_WAIT_POLICY ?= PASSIVE

# pytest rewrites the asserts of ~320 test modules on each run (10 s of each worker's collection)
# unless it may cache them as bytecode: with PYTHONDONTWRITEBYTECODE (set in some containers) the
# bytecode goes to a cache outside the working tree instead.
PYTEST = $(if $(PYTHONDONTWRITEBYTECODE),env -u PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX=$(CURDIR)/.venv/pycache) $(PY) -m pytest

.PHONY: install constraints lint test test-all coverage maps maps-armar6 maps-tiago demo bench bench-kitchen bench-eval eval robots clean docs

install: .venv/installed $(NUMBA_CACHE_DIR)/warm

# Installs the exact versions the suite passes with (constraints.txt); pyproject.toml holds the bounds.
.venv/installed: pyproject.toml constraints.txt
	python3 -m venv .venv
	.venv/bin/pip install -q --upgrade pip
	.venv/bin/pip install -q -c constraints.txt -e '.[test,dev,docs]'
	touch $@

# After an upgrade in .venv that passes `make test`: pin what is installed now.
constraints:
	{ sed -n '/^#/p' constraints.txt; .venv/bin/pip list --format=freeze --exclude-editable | grep -Ev '^(pip|setuptools|wheel)=='; } > constraints.txt.new
	mv constraints.txt.new constraints.txt

# Compiles every numba kernel into the cache, so that no command compiles on first use
# (84 s on 2 shared cores; again whenever a kernel source changes).
$(NUMBA_CACHE_DIR)/warm: .venv/installed $(wildcard placement/kernels/*.py)
	$(PY) -m placement.warmup
	touch $@

# Style and types: ruff (lint, format) over the package, tools and tests; mypy on the package
# (strict on planning, collision, storage, scene: see pyproject.toml).
lint: install
	.venv/bin/ruff check placement tools tests
	.venv/bin/ruff format --check placement tools tests
	.venv/bin/mypy

# The fast tier: everything not marked `slow` (kernels against their references, the programs against
# enumeration, parsers, the CLI through click's runner), two pytest-xdist workers, a test file on one
# worker (--dist loadfile: pyproject.toml). Run it while editing.
test: install
	$(PYTEST) -q -n 2 -m "not slow"

# Both tiers: the fast one and the integration tier marked `slow` (map builds, the docs build, Chromium,
# the warm-up, the ROS 2 node, commands as subprocesses, whole scenes); what CI runs.
test-all: install
	$(PYTEST) -q -n 2

# Line coverage of placement/ (pytest-cov, .coveragerc): the suite, then the kernel reference tests again
# with the numba JIT off (compiled kernels run as machine code coverage cannot see; these tests are fast
# enough in pure Python), the runs combined into one report with its total. Data in build/coverage.
KERNEL_TESTS = tests/test_linalg6.py tests/test_grid.py tests/test_kinematics.py tests/test_ranking.py \
	tests/test_navigation.py tests/test_isotropy_kernels.py tests/test_ik.py
# `make coverage TIER=fast`: the fast tier alone.
TIER ?= all
coverage: install
	rm -rf build/coverage && mkdir -p build/coverage
	$(PY) -m pytest -q -n 2 $(if $(filter fast,$(TIER)),-m "not slow") --cov=placement --cov-config=.coveragerc --cov-report=
	NUMBA_DISABLE_JIT=1 $(PY) -m pytest -q -n 2 --cov=placement --cov-config=.coveragerc --cov-append --cov-report= \
		$(KERNEL_TESTS) -k "not batched_kernel_proves and not row_penalties"
	$(PY) -m coverage report --rcfile=.coveragerc

# The documentation site into site/; --strict: any warning (a broken link, a page missing from the nav,
# a docstring that does not match its signature) fails the build. The benchmark tables it includes are
# the files `make bench`, `make bench-eval` and `make eval` write.
docs: .venv/installed
	NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict --site-dir site

maps: install
	$(PY) -m placement.cli.main maps build --robot pr2 --spec maps/pr2.yaml --out maps/pr2

maps/pr2/zarr.json:
	$(MAKE) maps

# ARMAR-6 (the paper's robot; its URDF is test data in ../shared/robots/armar6) for `make bench`.
maps-armar6: install
	$(PY) -m placement.cli.main maps build --spec maps/armar6.yaml --out maps/armar6

maps/armar6/zarr.json:
	$(MAKE) maps-armar6

# Builds the default maps if they are missing, then plans the example scenes: the table-clearing
# scene and the version 2 kitchen (drawer pull, side grasps on a shelf, a can lying on its side),
# both with the collision check on (the planner's default); figures in demo-plots/.
demo: install maps/pr2/zarr.json
	.venv/bin/placement query examples/table_clearing.yaml --plot demo-plots
	.venv/bin/placement query examples/kitchen.yaml --plot demo-plots/kitchen

# TIAGo (unedited `robots init` preset) with its lift settings, for the torso kitchen.
maps-tiago: install
	$(PY) -m placement.cli.main maps build --spec maps/tiago.yaml --out maps/tiago

maps/tiago/zarr.json:
	$(MAKE) maps-tiago

# The torso kitchens (high shelf, low table) planned by PR2 and TIAGo: docs/bench/kitchen_plan.md; the
# version 2 kitchen example (drawer, side grasps, the lying can): docs/bench/kitchen_example.md.
bench-kitchen: install maps/pr2/zarr.json maps/tiago/zarr.json
	$(PY) tools/bench_kitchen.py examples/kitchen_torso.yaml examples/kitchen_torso_tiago.yaml
	$(PY) tools/bench_kitchen.py examples/kitchen.yaml --out docs/bench/kitchen_example.md

bench: install maps/pr2/zarr.json maps/armar6/zarr.json
	$(PY) tools/bench.py
	$(PY) tools/bench_query.py
	$(PY) tools/bench_collision.py --maps maps/pr2
	$(PY) tools/bench_optimum.py --maps maps/pr2
	$(PY) tools/bench_buildings.py --maps maps/pr2
	$(PY) tools/bench_limits.py --maps maps/pr2
	$(PY) tools/bench_ros.py --maps maps/pr2

# The 45 free scenes of `make eval`: serial, 2 local processes and a 2-worker Dask LocalCluster.
bench-eval: install maps/pr2/zarr.json
	$(PY) tools/bench_eval.py --maps maps/pr2

# The paper's protocol: 45 scenes without and 30 with obstacles, all methods; results in docs/eval.
# The scenes record maps/pr2 relative to themselves (the default of `scenes generate` run from here).
eval: install maps/pr2/zarr.json
	rm -rf build/eval-scenes
	.venv/bin/placement scenes generate --seed 1 --count 45 --out build/eval-scenes/free -q
	.venv/bin/placement scenes generate --seed 1 --count 30 --obstacles --out build/eval-scenes/obstacles -q
	.venv/bin/placement evaluate build/eval-scenes/free --out docs/eval/free
	.venv/bin/placement evaluate build/eval-scenes/obstacles --out docs/eval/obstacles

# Issue 9's generality check: robots init -> maps build -> a scene sized from the reach band -> plan ->
# FK verify, for example-robot-data robots no test uses (maps in maps/<robot>, built when missing).
robots: install
	$(PY) tools/onboard_robots.py tiago talos_reduced romeo centauro so_arm_base lift_telescope

clean:
	rm -rf .venv build *.egg-info .pytest_cache
