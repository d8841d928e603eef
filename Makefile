# catpose: two commands.
#   make demo   set up .venv (CPU torch, open3d-cpu) and run ICP and ours on the embedded data under the
#               portable numeric profile the README's tables were made under, then print their table
#   make test   the default test suite (slow and experiment tests excluded; `make test-slow`, `make test-experiments` run them)
#   make lint   ruff, and the tests that check the repository rather than behaviour (module size, import rules, ...)
#   make cluster  the optional Hydra launchers (joblib, Slurm via submitit, Ray): docs/scale-out.md
#   make results  every table and figure the docs quote, regenerated (hours), then copied into the docs
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
BENCH := $(VENV)/bin/bench
TORCH_PIN ?= torch==2.13.0

.PHONY: setup demo test lint test-slow test-experiments regress realcheck results quotes cluster slurm-check clean

setup: $(VENV)/.installed

# torch is the `torch` extra, pinned here (TORCH_PIN; the CPU wheel on this machine): an unpinned
# torch pulls a multi-GB CUDA build on Linux (docs/install.md: the CPU wheel elsewhere).
# open3d-cpu's missing libusb-1.0.so.0 comes from the PyPI package libusb-package: it is linked into
# Open3D's folder (catpose.open3d_libusb) so that `import open3d` works before or without catpose.
# PYTHONWARNINGS: setuptools' notice that every editable install prints, not a problem of this one.
# No GPL package is installed (K-medoids is catpose's own PAM).
$(VENV)/.installed: pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet $(TORCH_PIN)
	PYTHONWARNINGS="ignore:Editable installation" $(PY) -m pip install --quiet -c constraints.txt -e ".[torch,test,ppf]"
	$(PY) -m catpose.open3d_libusb
	touch $@

# ICP and ours on the embedded set (outputs/demo/) under the portable numeric profile the README's
# tables are made under (same figures on any x86-64 CPU with AVX2), their tables, and the README's
# rows beside them (the time column is this machine's).
DEMO := outputs/demo
demo: setup
	eval "$$($(PY) -m catpose.bench.run.environment portable)" && \
	for m in icp ours; do $(BENCH) run method=$$m dataset=synthetic output_root=$(DEMO) print_summary=false || exit 2; done
	$(BENCH) report $(DEMO)/synthetic-gt_model --out $(DEMO)/report --force --no-pictures >/dev/null
	@for t in per_category summary; do cat $(DEMO)/report/tables/gt_model_$$t.md; echo; done
	@echo "The README's rows (results/report/tables/gt_model_summary.md):"
	@grep -E '^\| (Methods|---|ICP|Ours) ' results/report/tables/gt_model_summary.md

test: setup
	$(VENV)/bin/pytest -m "not slow and not experiment" -q

# Repository hygiene: ruff clean and ruff formatted (pyproject.toml [tool.ruff]), then the tests that
# check the repository, not behaviour: the module-size rule, the import rules, the studies' layout,
# the changelog's format, the docs' quotes of results/ and their links.
LINT_TESTS := tests/test_module_size.py tests/test_product_size.py tests/test_import_rules.py tests/test_experiments_layout.py \
	tests/test_changelog.py tests/test_doc_quotes.py
lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/pytest -q $(LINT_TESTS)

test-slow: setup
	$(VENV)/bin/pytest -m slow -q

# the tests of the studies' scripts (experiments/: grids read from stored runs)
test-experiments: setup
	$(VENV)/bin/pytest -m experiment -q

regress: setup
	$(BENCH) regress

# every method on ../shared/data (YCB-V, TYO-L, ModelNet40 resampled), one table; skips without the data.
# CPU-heavy (about an hour on 2 cores): runs under nice and resumes where it stopped.
realcheck: setup
	nice $(BENCH) suite real --force --write results/real/table.md

# Every table and figure the README and docs/ quote: results/make_results.sh (all sections; resumes
# where it stopped; SECTIONS="category real" for some), which runs the studies' scripts in experiments/,
# then the docs' quotes copied from the new files.
results: setup
	bash results/make_results.sh $(SECTIONS)
	$(PY) tools/doc_quotes.py

# The docs' quotes copied from results/ (docs/developing.md, "Regenerating the results").
quotes: setup
	$(PY) tools/doc_quotes.py

# The launchers extra (`pip install -e ".[cluster]"`), with the same pins as `make setup`.
cluster: $(VENV)/.cluster
$(VENV)/.cluster: $(VENV)/.installed pyproject.toml
	$(PY) -m pip install --quiet -c constraints.txt -e ".[torch,test,ppf,cluster]"
	touch $@

# A real single-node Slurm on this machine (Debian's slurm-wlm and munge, root only), then a
# 2-job sweep through hydra-submitit-launcher; not part of `make test`.
slurm-check: cluster
	bash tools/slurm_local.sh check

clean:
	rm -rf outputs build dist *.egg-info
