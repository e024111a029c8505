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

# `make bench` (full) or `make bench QUICK=1` (small sizes): every benchmark, one
# report in benchmarks/out/README.md; the Blender one needs bpy, so it runs as a script.
BENCH_FLAGS := $(if $(QUICK),--quick,)
bench: setup
	$(PY) benchmarks/bench_blender.py --out benchmarks/out/blender $(BENCH_FLAGS)
	$(VENV)/bin/vtcore bench --out benchmarks/out $(BENCH_FLAGS) --with benchmarks/out/blender

extension: setup
	$(PY) scripts/build_extension.py

clean:
	rm -rf out dist build benchmarks/out
