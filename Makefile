# seagen — set-up, demo, tests. Every target creates/updates .venv first.
VENV   ?= .venv
PY     := $(VENV)/bin/python
PIP    := $(VENV)/bin/pip
STAMP  := $(VENV)/.seagen-installed
DEMO   ?= demo_out
JOBS   ?= 2

.PHONY: venv toolchain demo test test-slow check format bench docs clean

$(PY):
	python3 -m venv $(VENV)

# torch first (the local CPU wheel), then the package with its dev extras.
$(STAMP): $(PY) pyproject.toml
	$(PIP) install -q --upgrade pip
	$(PIP) install -q torch==2.13.0
	$(PIP) install -q -e '.[dev]'
	touch $(STAMP)

venv: $(STAMP) toolchain qemu

# The Arm cross compiler, from Debian, when root and missing.
toolchain:
	@if ! command -v arm-none-eabi-gcc >/dev/null 2>&1; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    echo "installing gcc-arm-none-eabi libnewlib-arm-none-eabi"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gcc-arm-none-eabi libnewlib-arm-none-eabi >/dev/null; \
	  else echo "warning: arm-none-eabi-gcc missing and not root; Cortex-M tests will be skipped"; fi; \
	fi
	@# cppcheck (Debian 12's 2.10, with its MISRA C:2012 addon) for tests/test_misra.py and verify --misra.
	@if ! command -v cppcheck >/dev/null 2>&1; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    echo "installing cppcheck"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq cppcheck >/dev/null; \
	  else echo "warning: cppcheck missing and not root; the MISRA checks will be skipped"; fi; \
	fi
	@# cmake and ninja for tests/test_cmake_package.py (the export folder built as a CMake package);
	@# arduino-builder with its AVR core for tests/test_packages.py (the package's Arduino example for an Uno);
	@# gcc-avr, avr-libc and simavr for tests/test_avr.py (the portable C on an ATmega328P, 16-bit int).
	@# frama-c-base (Debian 12's Frama-C 25.0 Manganese) for verify --prove and tests/test_prove.py (docs/prove.md).
	@for tool in cmake:cmake ninja:ninja-build arduino-builder:arduino-builder+arduino-core-avr frama-c:frama-c-base avr-gcc:gcc-avr+avr-libc simavr:simavr; do \
	  cmd=$${tool%%:*}; pkg=$$(echo $${tool#*:} | tr + ' '); \
	  if ! command -v $$cmd >/dev/null 2>&1; then \
	    if [ "$$(id -u)" = "0" ]; then \
	      echo "installing $$pkg"; \
	      apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$pkg >/dev/null; \
	    else echo "warning: $$cmd missing and not root; the CMake package tests will be skipped or use make"; fi; \
	  fi; \
	done


# QEMU's Arm system emulator (processor-in-the-loop boards), from Debian, when root and missing.
.PHONY: qemu
qemu:
	@if ! command -v qemu-system-arm >/dev/null 2>&1; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    echo "installing qemu-system-arm"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-system-arm >/dev/null; \
	  else echo "warning: qemu-system-arm missing and not root; processor-in-the-loop tests will be skipped"; fi; \
	fi

demo: venv
	$(VENV)/bin/seagen demo --out $(DEMO)

test: venv
	$(PY) -m pytest -n $(JOBS) --dist worksteal -q --durations=15

test-slow: venv
	$(PY) -m pytest -n $(JOBS) --dist worksteal -q -m slow --durations=15

check: venv
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy

format: venv
	$(VENV)/bin/ruff format .
	$(VENV)/bin/ruff check --fix .

# seagen's kernels (portable and per core) against emlearn's float MLP and a plain float loop, on emulated
# Cortex-M4 and M0+ (the glove also at one flash wait state); writes the tables between the bench markers of
# docs/benchmarks.md (~2.5 min).
bench: venv
	$(PY) -m seagen.bench.compare --readme docs/benchmarks.md --flash-wait 1

# The manual (mkdocs.yml, pages in docs/, the command reference rendered from the parsers) as a site in site/.
docs: venv
	$(VENV)/bin/mkdocs build --strict --site-dir site

clean:
	rm -rf $(DEMO) build dist *.egg-info .pytest_cache
