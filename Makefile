# Every target sets itself up on a fresh machine: it creates .venv if missing and installs.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1

.PHONY: install warmup test lint docs demo bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	$(PY) -m inmotion.warmup || echo "inmotion: warm-up failed; numba compiles at first use instead"
	touch $(STAMP)

install: $(STAMP)

# compile the numba kernels the demo uses (part of install; again after editing a kernel)
warmup: $(STAMP)
	$(PY) -m inmotion.warmup

lint: $(STAMP)
	$(PY) -m ruff check src tests benchmarks tools docs

test: lint
	$(PY) -m pytest -q -n 2 --dist loadfile

DOCS_STAMP := $(VENV)/.docs-stamp

$(DOCS_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install -q -e '.[docs]'
	touch $(DOCS_STAMP)

# the documentation site (user guide, reference, API from the docstrings) into site/;
# --strict: every warning is an error
docs: $(DOCS_STAMP)
	$(PY) -m mkdocs build --strict -d site

demo: $(STAMP)
	$(VENV)/bin/inmotion demo

bench: $(STAMP)
	$(PY) benchmarks/run_all.py

clean:
	rm -rf $(VENV) build site *.egg-info src/*.egg-info .pytest_cache
