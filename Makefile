# fenics-plast: make demo | test | test-slow | bench | keys | docs | fresh-check[-bookworm|-trixie]
SHELL := /bin/bash
PY    := .venv/bin/python
FP    := .venv/bin/fenics-plast

# Open MPI refuses to run as root without these (containers, CI).
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1

.PHONY: install demo test test-slow bench keys docs fresh-check fresh-check-bookworm fresh-check-trixie clean

install:
	bash scripts/install.sh

# Every demos/*.toml into results/<scene name>/ (the CLI's default); keeps going, fails at the end.
demo: install
	@failed=""; shopt -s nullglob; scenes=(demos/*.toml); \
	if [ $${#scenes[@]} -eq 0 ]; then echo "make demo: no demos/*.toml yet"; fi; \
	for s in "$${scenes[@]}"; do \
	    echo "== $$s"; \
	    $(FP) run "$$s" || failed="$$failed $$s"; \
	done; \
	echo "make demo: results are in $(CURDIR)/results/<scene name>/ (summary.json, history.csv, fields.xdmf, *.png)"; \
	if [ -n "$$failed" ]; then echo "make demo: FAILED:$$failed"; exit 1; fi

test: install
	$(PY) -m pytest -q tests

test-slow: install
	$(PY) -m pytest -q -m '' tests

bench: install
	@shopt -s nullglob; for b in benchmarks/*.py; do echo "== $$b"; $(PY) "$$b" || exit 1; done

# Regenerate docs/SCENE_KEYS.md from the schema in fenics_plast/schema.py.
keys: install
	$(PY) -m fenics_plast.keys_doc

# The user guide (docs/*.md, docs/guide/*.md) with Debian's Sphinx and MyST into docs/_build/html/: every page
# read again (-E), warnings as errors (a broken link or anchor, a literal include whose file or marker is gone).
docs: install
	$(PY) -m sphinx -W --keep-going -E -q -b html docs docs/_build/html
	@echo "make docs: open $(CURDIR)/docs/_build/html/index.html in a browser"

# `make docs` and the README's two commands on a new minimal Debian root (debootstrap + chroot, the
# Dockerfile's steps), Debian 12 bookworm and Debian 13 trixie at the same time, or one of them; needs
# root. Times: see docs/guide/install.md ("Fresh-machine check").
fresh-check:
	bash scripts/fresh_root_check.sh

fresh-check-bookworm:
	bash scripts/fresh_root_check.sh bookworm

fresh-check-trixie:
	bash scripts/fresh_root_check.sh trixie

clean:
	rm -rf results docs/_build
