PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
LOCK := requirements.lock
# Installs take the exact versions the suite last passed with; `make upgrade` moves them on.
CONSTRAINTS ?= -c $(LOCK)

.PHONY: demo test test-fast docs bench bench-peers lint clean serve lock upgrade fuzz flowers \
	gpu-check

$(STAMP): pyproject.toml $(LOCK)
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet "pip==26.3"
	$(BIN)/pip install --quiet $(CONSTRAINTS) -e ".[dev,all]"
	touch $(STAMP)

lock: $(STAMP)
	$(BIN)/pip freeze --exclude-editable > $(LOCK).tmp && mv $(LOCK).tmp $(LOCK)

upgrade:
	rm -rf $(VENV)
	$(MAKE) CONSTRAINTS= test
	$(MAKE) lock

demo: $(STAMP)
	$(BIN)/morphogen demo --out out/demo

flowers: $(STAMP)
	$(BIN)/morphogen gallery flowers --out out/flowers

# ruff, then the layer rule and the ban on import circles (pyproject.toml [tool.importlinter]),
# then the type check of the public modules ([tool.mypy]).
lint: $(STAMP)
	$(BIN)/ruff check morphogen tests bench fuzz
	$(BIN)/lint-imports --no-cache
	$(BIN)/mypy

# Three workers on the two cores, a file each; each worker's XLA runs on one thread. Many tests
# wait part of the time (on a browser, a server's job, Ray's workers, a subprocess), and a third
# worker fills those waits (1.80 cores busy on average with three). On the 2-core development
# machine the whole suite took 549 s and, from a clean clone, 638 s with three; 625 s with two
# on a quiet hour, 673-757 s with other work beside it. Most of the suite's time is compiling
# small programs, so LLVM's costliest optimisation passes are skipped and its backend runs at
# -O1: the programs compute the same (IEEE semantics either way), compiled in about half the
# time (-O1 takes another 12-14 % of the suite's CPU time off, on compile-heavy and run-heavy
# files alike). XLA's older LLVM emitters for fusions compile faster still than its newer MLIR
# fusion emitters: 30 % less CPU time on compile-heavy test files (57 -> 40 CPU-s) and 37 % on
# run-heavy ones (103 -> 65 CPU-s: neural training, a flower, network fitness), one core each;
# the whole suite went from 786 s to 506 s (a clone with its environment built, quiet machine).
# The flags are the suite's only: runs outside it use XLA's defaults.
XLA_CPU := JAX_PLATFORMS=cpu XLA_FLAGS="--xla_cpu_multi_thread_eigen=false --xla_llvm_disable_expensive_passes=true --xla_backend_optimization_level=1 --xla_cpu_use_fusion_emitters=false"

# Lint and the API reference first, side by side on the two cores (mypy from a clean clone takes
# about 9 s, the reference 14 s).
test: $(STAMP)
	$(MAKE) --no-print-directory -j2 lint docs
	$(XLA_CPU) $(BIN)/python -m pytest -n 3 --dist loadfile --durations=20

# The inner loop while editing: the suite without the tests marked slow (browser, neural
# training, Ray, flower case studies, long command-line runs: about two thirds of its time).
test-fast: $(STAMP) lint
	$(XLA_CPU) $(BIN)/python -m pytest -n 3 --dist loadfile -m "not slow" --durations=10

# The API reference from the docstrings, in out/api/; fails on a module that does not import or
# a docstring reference to something that does not exist (docs/api.py).
docs: $(STAMP)
	JAX_PLATFORMS=cpu $(BIN)/python docs/api.py --out out/api

serve: $(STAMP)
	$(BIN)/morphogen serve --port $(or $(PORT),8000)

bench: $(STAMP)
	$(BIN)/python -m bench.run

# The GPU-relevant checks and benchmarks on whatever JAX backend is present, at most 8 minutes on
# one GPU, into bench/results/gpu.json (docs/schemes.md); on a CPU at tiny sizes.
gpu-check: $(STAMP)
	$(BIN)/python -m bench.gpu_check

# Against Exponax and py-pde: the peers live in their own environment, .venv-bench (the lock
# plus bench/peers.txt), never in the project's dependencies.
bench-peers:
	test -x .venv-bench/bin/python || $(PY) -m venv .venv-bench
	.venv-bench/bin/pip install --quiet "pip==26.3"
	.venv-bench/bin/pip install --quiet -c $(LOCK) -e .
	.venv-bench/bin/pip install --quiet -c $(LOCK) -r bench/peers.txt
	.venv-bench/bin/python -m bench.bench_peers

fuzz: $(STAMP)
	$(BIN)/python -m fuzz.run --seconds $(or $(SECONDS),600)

clean:
	rm -rf out .pytest_cache
