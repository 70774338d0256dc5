# xpflow — the two set-up commands a new user needs are `make demo` and `make test`.
# Both install what a fresh Debian 12 machine with Rust and Python lacks (HDF5 headers).
# One cargo profile (release) serves tests, demo, validation and benchmarks, so CI builds once.

CARGO   ?= cargo
PROFILE := --release
BIN     := $(or $(CARGO_TARGET_DIR),target)/release/xpflow
SUDO    := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps build test lint demo validate bench figures clean-results

all: build

# System packages: libhdf5-dev + pkg-config for the HDF5 bindings (hdf5-metno).
deps:
	@if ! pkg-config --exists hdf5 2>/dev/null && [ ! -f /usr/include/hdf5/serial/hdf5.h ]; then \
		echo "installing libhdf5-dev and pkg-config (apt)"; \
		$(SUDO) apt-get update -qq && $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libhdf5-dev pkg-config; \
	fi

build: deps
	$(CARGO) build $(PROFILE)

# Fast checks (unit tests, convergence on coarse meshes, CLI); heavy studies are `make validate`.
test: deps
	$(CARGO) test $(PROFILE)

lint: deps
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy $(PROFILE) --all-targets -- -D warnings

# A small real sweep: two particles in confined shear flow, Newtonian and Giesekus (sweeps/demo.toml), its results
# database (results/demo.db, resumable: a rerun skips finished cases), its table and its figures.
demo: build figures-deps
	$(BIN) sweep sweeps/demo.toml --db results/demo.db
	$(BIN) query cases --db results/demo.db --sweep demo
	$(MAKE) --no-print-directory figures DB=results/demo.db
	@echo "demo: database results/demo.db, figures in results/figures/demo/"

# Heavy validation studies; record their output in docs/validation.md.
validate: build
	$(BIN) validate stokes-mms --levels 5
	$(BIN) validate couette --levels 5
	$(BIN) validate xfem-stokes --levels 5
	$(BIN) validate cylinder --wi 0
	$(BIN) validate free-particle
	$(BIN) validate two-particles
	$(BIN) validate cylinder --wi 0.3 --h 0.1,0.05 --dt 0.01 --t-max 15
	$(BIN) validate cylinder --wi 0.6 --h 0.1,0.05 --dt 0.01 --t-max 30
	$(BIN) validate translating-cylinder --h 0.125
	$(BIN) validate explicit-coupling --h 0.25
	$(BIN) validate semi-implicit-coupling --h 0.25
	$(BIN) validate variable-steps --h 0.125
	$(BIN) validate lab-frame
	$(BIN) validate couette-frame
	$(BIN) validate near-contact
	$(BIN) validate film-polymer
	$(BIN) validate extrudate-swell --graded --h 0.05,0.025,0.0125 --de 0,0.25,0.5,0.6,0.75
	$(CARGO) test $(PROFILE) -- --ignored

# Benchmarks; record their output in docs/performance.md.
bench: build
	$(BIN) bench stokes --mesh 200x50
	$(BIN) bench stokes --mesh 200x50 --with-g
	$(BIN) bench stokes --mesh 440x110
	$(BIN) bench stokes --mesh 440x110 --with-g
	$(BIN) bench stokes --mesh 200x50 --solver lu --repeats 2
	$(BIN) bench drag
	$(BIN) bench moving --mesh 100x25,200x50,300x75,440x110 --particles 3
	$(BIN) bench moving --mesh 200x50 --particles 1,6,9
	$(BIN) bench moving --sweep sweeps/beta_near_contact.toml --case 6944d776  # a/12 study case, from rest
	$(BIN) bench expand

# Figures and tables from results databases (plotting/, docs/figures.md): `make figures` plots every
# results/*.db, `make figures DB=results/demo.db` one (or several, space-separated) into results/figures/<db>/,
# `make figures DATA=data/thesis` every database of a shipped dataset into data/thesis/figures/<db>/
# (docs/reproduction.md; the databases are made by `xpflow export --thin`).
# figures-deps makes the Python virtual environment .venv/ with plotting/requirements.txt (reinstalled when
# that file changes); it needs python3 >= 3.11 with venv/pip (installs Debian's python3-venv if missing).
DB      ?=
DATA    ?=
VENV    := .venv
ifneq ($(DATA),)
DB      := $(wildcard $(DATA)/*.db)
FIG_OUT ?= $(DATA)/figures
endif
FIG_OUT ?= results/figures

.PHONY: figures-deps
figures-deps: $(VENV)/.requirements-installed

$(VENV)/.requirements-installed: plotting/requirements.txt
	@command -v python3 >/dev/null 2>&1 || { echo "figures-deps: python3 not found; install Python >= 3.11 (Debian: apt-get install python3 python3-venv)" >&2; exit 1; }
	@python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' || { echo "figures-deps: python3 is $$(python3 -V 2>&1); plotting/requirements.txt needs Python >= 3.11" >&2; exit 1; }
	@if ! python3 -c 'import venv, ensurepip' 2>/dev/null; then \
		echo "installing python3-venv (apt)"; \
		$(SUDO) apt-get update -qq && $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv python3-pip \
		|| { echo "figures-deps: python3 has no venv/ensurepip (pip) and python3-venv could not be installed" >&2; exit 1; }; \
	fi
	python3 -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --disable-pip-version-check -r plotting/requirements.txt \
		|| { echo "figures-deps: pip could not install plotting/requirements.txt (needs PyPI)" >&2; exit 1; }
	@touch $@

figures: figures-deps
ifneq ($(DATA),)
	@test -n "$(DB)" || { echo "figures: no *.db in $(DATA)" >&2; exit 2; }
endif
	$(VENV)/bin/python plotting/make_figures.py --out $(FIG_OUT) $(DB)

clean-results:
	rm -rf results/*
	touch results/.gitkeep
