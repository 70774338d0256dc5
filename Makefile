# xpflow — the two set-up commands a new user needs are `make demo` and `make test`.
# Both install what a fresh Debian 12 machine with Rust and Python lacks (HDF5 headers).
# One cargo profile (release) serves tests, demo, validation and benchmarks, so CI builds once.

CARGO   ?= cargo
PROFILE := --release
BIN     := target/release/xpflow
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

# A small real run: today the validated solver studies (the particle sweep engine is issue 6;
# `make demo` will run sweeps/demo.toml and write its database and figures once it lands).
demo: build
	@mkdir -p results/demo
	$(BIN) validate stokes-mms --levels 4 | tee results/demo/stokes-mms.md
	$(BIN) validate couette --levels 4 | tee results/demo/couette.md
	$(BIN) bench stokes --mesh 100x25 --repeats 3 | tee results/demo/bench-stokes.txt
	@echo "demo outputs written to results/demo/"

# Heavy validation studies; record their output in docs/validation.md.
validate: build
	$(BIN) validate stokes-mms --levels 5
	$(BIN) validate couette --levels 5
	$(CARGO) test $(PROFILE) -- --ignored

# Benchmarks; record their output in docs/performance.md.
bench: build
	$(BIN) bench stokes --mesh 200x50
	$(BIN) bench stokes --mesh 200x50 --with-g
	$(BIN) bench stokes --mesh 440x110
	$(BIN) bench stokes --mesh 440x110 --with-g
	$(BIN) bench stokes --mesh 200x50 --solver lu --repeats 2

figures:
	@echo "figures are not built yet (issue 7)"; exit 3

clean-results:
	rm -rf results/*
	touch results/.gitkeep
