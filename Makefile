# Set-up and everyday commands. `make demo` and `make test` are all a fresh
# machine needs (Debian/Ubuntu, Python >= 3.10); see README.md.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
SCENES ?= 1000
WORKERS ?= $(shell nproc 2>/dev/null || echo 1)

.PHONY: all venv sysdeps demo test shards bench assets-sheet clean

all: test

# open3d links against libusb-1.0; Debian images often lack it.
sysdeps:
	@if ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing libusb-1.0-0 (needed by open3d)"; \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libusb-1.0-0 >/dev/null; \
	else \
		echo "error: open3d needs libusb-1.0.so.0; run 'sudo apt-get install libusb-1.0-0' and try again" >&2; exit 1; \
	fi

venv: $(STAMP)

$(STAMP): pyproject.toml | sysdeps
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[test,torch,ray]"
	@touch $@

# A small dataset with the default recipe, then its statistics.
demo: venv
	$(BIN)/refspatial generate --scenes 20 --out data/demo --workers $(WORKERS)
	$(BIN)/refspatial stats data/demo

test: venv
	$(BIN)/python -m pytest

# The default dataset: $(SCENES) tabletop scenes in ./data (see README for size and time).
shards: venv
	$(BIN)/refspatial generate --scenes $(SCENES) --out data/tabletop --workers $(WORKERS)
	$(BIN)/refspatial stats data/tabletop

bench: venv
	$(BIN)/python benchmarks/bench.py --scenes 12 --workers $(WORKERS) --families 4 --library-assets 2000  # 1 process, then all cores, the other recipes, a 2,000-asset library

# The contact sheet of every asset category (docs/assets.png).
assets-sheet: venv
	$(BIN)/python scene_assets/contact_sheet.py

clean:
	rm -rf $(VENV) data/demo .pytest_cache
