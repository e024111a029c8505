# The two commands of the README are `make demo` and `make test`; each sets up
# the pinned virtual environments and the Debian packages they need first.
# Two lanes, one per Blender generation (docs/blender.md):
#   py311: .venv    Python 3.11, numpy 1.26, bpy 4.5 LTS (requirements.lock)       Blender 4.2 LTS .. 5.0
#   py313: .venv313 Python 3.13, numpy 2,    bpy 5.2 LTS (requirements-py313.lock) Blender 5.1, 5.2 LTS
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
PY313 := .venv313/bin/python
OUT ?= out/demo
PYTEST := -m pytest -q -n 2 --dist loadfile

.PHONY: setup demo test test-fast bench extension clean

setup:
	@scripts/setup.sh

demo:
	@scripts/setup.sh py311
	$(VENV)/bin/vtcore run scenes/demo.toml --out $(OUT)
	@echo "demo: open $(OUT)/report.md"

# Both lanes run even when the first fails; the exit status says whether both passed. The CPU
# seconds (workers included) say what a lane costs when the machine is shared.
test: setup
	@rc=0; for py in $(PY) $(PY313); do \
	    echo "== lane $$($$py -c 'import sys, numpy, bpy; print(f"Python {sys.version.split()[0]}, numpy {numpy.__version__}, bpy {bpy.app.version_string}")')"; \
	    TIMEFORMAT="== lane took %0R s wall, %0U s user + %0S s sys CPU"; time $$py $(PYTEST) $(ARGS) || rc=1; \
	done; exit $$rc

test-fast: ARGS = -m "not slow"
test-fast: test

bench:
	@scripts/setup.sh py311
	$(VENV)/bin/vtcore bench --out benchmarks/out

# One zip per generation, each built, checked and validated by its own interpreter and
# its own bpy's blender_ext.py: dist/vtskin-<version>-py311.zip and -py313.zip.
extension: setup
	$(PY) scripts/build_extension.py
	$(PY313) scripts/build_extension.py

clean:
	rm -rf out dist build benchmarks/out
