# The two commands of the README are `make demo` and `make test`; each sets up
# .venv (pinned, see requirements.lock) and the Debian packages it needs first.
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
OUT ?= out/demo

.PHONY: setup demo test test-fast bench extension clean

setup:
	@scripts/setup.sh

demo: setup
	$(VENV)/bin/vtcore run scenes/demo.toml --out $(OUT)
	@echo "demo: open $(OUT)/report.md"

test: setup
	$(PY) -m pytest -q -n 2 --dist loadfile

test-fast: setup
	$(PY) -m pytest -q -n 2 --dist loadfile -m "not slow"

bench: setup
	$(VENV)/bin/vtcore bench --out benchmarks/out

extension: setup
	$(PY) scripts/build_extension.py

clean:
	rm -rf out dist build benchmarks/out
