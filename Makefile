# The two commands of the README. Both create .venv and install everything on a fresh machine.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test install lint bench docs docs-serve orig-venv clean

# The install also builds the fused BIARM kernels (~30-60 s once per machine), so neither the
# first run nor the first test pays for it; without a compiler it prints why, and runs use the
# PyTorch/NumPy path.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[all]'
	$(BIN)/python -c "from evodevo.neuromod import kernels as k; k.load() or print('evodevo: fused kernels not built:', k._error)"
	touch $(STAMP)

install: $(STAMP)

run: $(STAMP)
	$(BIN)/evodevo reproduce --budget quick --out runs/quick

test: $(STAMP)
	$(BIN)/python -m pytest -q -p no:cacheprovider

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/mypy src

bench: $(STAMP)
	$(BIN)/python -m benchmarks --json

# The documentation site (mkdocs.yml): pages of docs/ and the API reference from the docstrings.
docs: $(STAMP)
	$(BIN)/mkdocs build --strict
	@echo "site: build/site/index.html"

docs-serve: $(STAMP)
	$(BIN)/mkdocs serve

# The original pybullet_envs Kuka env for benchmarks/env_speed.py: it needs the dead gym 0.23.1,
# so it lives in its own venv and is never a dependency of evodevo (SPEC §3).
orig-venv:
	test -x .venv-orig/bin/python || $(PY) -m venv .venv-orig
	.venv-orig/bin/pip install -q pybullet==3.2.7 gym==0.23.1 'setuptools<82' numpy

clean:
	rm -rf $(VENV) .venv-orig runs
