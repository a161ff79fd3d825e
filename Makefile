# The two commands a user needs: `make reproduce` and `make test`. The first run of either creates
# .venv and installs the project with the pinned versions of constraints.txt; `make test` adds the
# test dependencies (pytest, and pytest-xdist: the tests run in two processes; MkDocs, whose strict
# build of the documentation is a test); `make docs` writes the generated pages and builds the site.
# Mitsuba's fast variant (llvm_ad_rgb) needs a shared LLVM >= 15, and the LLVM 15 of Debian 12
# aborts every render: as root on Debian, Debian's libllvm19 is installed; elsewhere, or if that
# fails, the pipeline uses scalar_rgb. The Makefile only installs: the pipeline finds its tools
# itself (`pipeline.engine.toolchains`: LLVM, Mesa's RADV) and sets JAX's float64 and CPU platform
# itself, so a command run here is the command a user runs without `make`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
INSTALLED := $(VENV)/.installed
TEST_INSTALLED := $(VENV)/.installed-test
DOCS_INSTALLED := $(VENV)/.installed-docs
PIP := $(BIN)/pip install --quiet --disable-pip-version-check -c constraints.txt
# uv (PyPI's, pinned) installs the pinned packages in about 10 s where pip takes about a minute (both
# measured here, with their caches warm); where uv is absent or fails, pip installs them. Both write
# the packages' bytecode (pip does by default, uv with --compile-bytecode): where the environment sets
# PYTHONDONTWRITEBYTECODE, as this machine's does, no import writes it, and every process would compile
# jax, scipy and sympy from their sources again (importing jax, optimistix, pysindy and matplotlib
# took 7.6 s without it and 2.6 s with it, here).
INSTALL := installed() { if [ -x $(BIN)/uv ] && $(BIN)/uv pip install --quiet --compile-bytecode --python $(BIN)/python \
	-c constraints.txt "$$@"; then :; else $(PIP) "$$@"; fi; }; installed
# The pipeline's own bytecode, written before a command runs (only what changed is compiled again).
COMPILED := $(BIN)/python -m compileall -q pipeline
LLVM_READY := $(VENV)/.llvm
RADV_READY := $(VENV)/.radv
NVIDIA_READY := $(VENV)/.nvidia
INTEL_READY := $(VENV)/.intel
MOBILE_READY := $(VENV)/.mesa-arm64
SOLLYA_READY := $(VENV)/.sollya
CHROMIUM_READY := $(VENV)/.chromium
MESA_ARM64 := $(or $(PIPELINE_MESA_ARM64),/opt/pipeline/mesa-arm64)
CONFIG ?= configs/paper.toml
SET ?=
ONLY ?=

.PHONY: reproduce test test-isa bench refit clean keys graph docs measure fuzz

$(INSTALLED): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PIP) uv || echo "uv could not be installed: pip installs the packages"
	$(INSTALL) -e .
	touch $(INSTALLED)

$(TEST_INSTALLED): $(INSTALLED)
	$(INSTALL) -e ".[test,docs]"
	touch $(TEST_INSTALLED)

$(DOCS_INSTALLED): $(INSTALLED)
	$(INSTALL) -e ".[docs]"
	touch $(DOCS_INSTALLED)

# Best effort: a missing libllvm19 only means the slower scalar_rgb variant.
$(LLVM_READY): $(INSTALLED)
	@if ls /usr/lib/*/libLLVM.so.19* /usr/lib/llvm-19/lib/libLLVM.so* 2>/dev/null | grep -q .; then \
		echo "LLVM 19 found: Mitsuba runs llvm_ad_rgb"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing Debian's libllvm19 for Mitsuba's llvm_ad_rgb variant ..."; \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -q libllvm19 >/dev/null 2>&1 \
		|| (apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q libllvm19 >/dev/null 2>&1) \
		|| echo "libllvm19 could not be installed: Mitsuba falls back to scalar_rgb"; \
	else \
		echo "no LLVM 19 and no apt-get as root: Mitsuba falls back to scalar_rgb"; \
	fi
	touch $(LLVM_READY)

# Best effort: the gpu_isa stage compiles the lobes to AMD machine code with Mesa's RADV driver (no
# GPU needed); without it the stage says why and the report gives SPIR-V counts only.
$(RADV_READY): $(INSTALLED)
	@if ls /usr/share/vulkan/icd.d/radeon_icd*.json 2>/dev/null | grep -q . && ldconfig -p | grep -q libvulkan.so.1; then \
		echo "Mesa's RADV found: the gpu_isa stage compiles to AMD machine code"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing Debian's mesa-vulkan-drivers and libvulkan1 for the machine-code cost ..."; \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -q mesa-vulkan-drivers libvulkan1 >/dev/null 2>&1 \
		|| (apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q mesa-vulkan-drivers libvulkan1 >/dev/null 2>&1) \
		|| echo "mesa-vulkan-drivers could not be installed: the machine-code cost is not measured"; \
	else \
		echo "no RADV and no apt-get as root: the machine-code cost is not measured"; \
	fi
	touch $(RADV_READY)

# Best effort: Sollya and Gappa (Debian's sollya and gappa): Sollya's fpminimax the test of the
# constants chosen in float16 is compared with, its checkinfnorm and Gappa's proof the oracles of the
# certified error bounds; without them those tests say so and skip.
$(SOLLYA_READY): $(INSTALLED)
	@for tool in sollya gappa; do \
		if command -v $$tool >/dev/null; then \
			echo "$$tool found: the tests compare with it"; \
		elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
			echo "installing Debian's $$tool for the tests' comparisons ..."; \
			DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$tool >/dev/null 2>&1 \
			|| (apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$tool >/dev/null 2>&1) \
			|| echo "$$tool could not be installed: the comparisons with it are skipped"; \
		else \
			echo "no $$tool and no apt-get as root: the comparisons with it are skipped"; \
		fi; \
	done
	touch $(SOLLYA_READY)

# Best effort: Chromium (Debian's chromium), which Playwright drives to test the report.html pages
# (Playwright's own browser download is not used); without it those tests say so and skip.
$(CHROMIUM_READY): $(INSTALLED)
	@if command -v chromium >/dev/null || command -v chromium-browser >/dev/null; then \
		echo "Chromium found: the report pages are tested in it"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing Debian's chromium for the report pages' browser tests ..."; \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null 2>&1 \
		|| (apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null 2>&1) \
		|| echo "chromium could not be installed: the browser tests are skipped"; \
	else \
		echo "no chromium and no apt-get as root: the browser tests are skipped"; \
	fi
	touch $(CHROMIUM_READY)

# Best effort: NVIDIA's offline compiler (ptxas) and SASS disassembler from PyPI, pinned in
# constraints.txt (NVIDIA's EULA: installed here, never held in the repository); without them the
# NVIDIA machine code is not measured and the tests that need it say so.
$(NVIDIA_READY): $(INSTALLED)
	@$(INSTALL) nvidia-cuda-nvcc-cu12 nvidia-cuda-cuobjdump nvidia-cuda-nvdisasm \
		|| echo "NVIDIA's compilers could not be installed: NVIDIA machine code is not measured"
	touch $(NVIDIA_READY)

# Best effort: Intel's offline compiler (ocloc) and its disassembler's library (IGA), from Debian.
$(INTEL_READY): $(INSTALLED)
	@if command -v ocloc >/dev/null && ls /usr/lib/*/libiga64.so* 2>/dev/null | grep -q .; then \
		echo "Intel's ocloc found: the gpu_isa stage compiles to Intel machine code"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing Debian's intel-opencl-icd and libigc-tools for Intel machine code ..."; \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -q intel-opencl-icd libigc-tools >/dev/null 2>&1 \
		|| (apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q intel-opencl-icd libigc-tools >/dev/null 2>&1) \
		|| echo "intel-opencl-icd could not be installed: Intel machine code is not measured"; \
	else \
		echo "no ocloc and no apt-get as root: Intel machine code is not measured"; \
	fi
	touch $(INTEL_READY)

# Best effort: Mesa's compilers for Adreno (freedreno) and Mali (panfrost) on their drm-shim null
# devices, from Debian's arm64 packages run by qemu-user (scripts/install-mesa-arm64.sh: about 90 MB
# downloaded, unpacked into $(MESA_ARM64), this machine's packages untouched); without them the
# Adreno and Mali machine code is not measured.
$(MOBILE_READY): $(INSTALLED)
	@if command -v qemu-aarch64-static >/dev/null && [ -e "$(MESA_ARM64)/usr/lib/aarch64-linux-gnu/libpanfrost_noop_drm_shim.so" ]; then \
		echo "Mesa's arm64 compilers found in $(MESA_ARM64): the gpu_isa stage compiles for Adreno and Mali"; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing qemu-user-static and Mesa's arm64 compilers for Adreno and Mali machine code ..."; \
		bash scripts/install-mesa-arm64.sh "$(MESA_ARM64)" \
		|| echo "Mesa's arm64 compilers could not be installed: Adreno and Mali machine code is not measured"; \
	else \
		echo "no Mesa arm64 compilers and no apt-get as root: Adreno and Mali machine code is not measured"; \
	fi
	touch $(MOBILE_READY)

reproduce: $(INSTALLED) $(LLVM_READY) $(RADV_READY) $(NVIDIA_READY) $(INTEL_READY) $(MOBILE_READY)
	@$(COMPILED)
	$(BIN)/pipeline reproduce

refit: $(INSTALLED) $(LLVM_READY) $(RADV_READY) $(NVIDIA_READY) $(INTEL_READY) $(MOBILE_READY)
	$(BIN)/pipeline refit --config $(CONFIG) $(foreach s,$(SET),--set $(s)) $(if $(ONLY),--only $(ONLY))

# The compiled XLA programs are kept between runs in the pipeline's own folder (JAX keys each on its
# HLO, the XLA flags and the jaxlib version): a later `make test` compiles only what changed.
# `make test TEST_XLA_CACHE=` starts each session from an empty folder of its own (as a fresh clone does).
TEST_XLA_CACHE ?= $(CURDIR)/.cache/stages/_xla
test: $(TEST_INSTALLED) $(LLVM_READY) $(RADV_READY) $(NVIDIA_READY) $(INTEL_READY) $(MOBILE_READY) $(SOLLYA_READY) $(CHROMIUM_READY)
	@$(COMPILED)
	PIPELINE_XLA_CACHE_DIR="$(TEST_XLA_CACHE)" $(BIN)/python -m pytest -q -n 2 --dist loadfile

# The numerical tests (optics, symbolic regression, the stages and the checks against the paper)
# under three instruction sets: XLA compiles for the CPU it finds, so the last bits of every jitted
# result differ between machines; a tolerance that holds here must hold there. SSE4_2 and AVX2
# imitate older machines (AVX2 without AVX-512: the common cloud CPU); "native" leaves XLA_FLAGS
# unset. Each level runs in its own test session (its own caches); all three run, then the target
# fails if any did.
ISA_LEVELS ?= SSE4_2 AVX2 native
ISA_TESTS ?= tests/optics tests/symbolic tests/stages
test-isa: $(TEST_INSTALLED) $(LLVM_READY) $(RADV_READY) $(NVIDIA_READY) $(INTEL_READY) $(MOBILE_READY)
	@$(COMPILED)
	@failed=""; for isa in $(ISA_LEVELS); do \
		if [ "$$isa" = native ]; then flags=""; else flags="--xla_cpu_max_isa=$$isa"; fi; \
		echo "== XLA_FLAGS=$$flags ($$isa)"; \
		XLA_FLAGS="$$flags" PIPELINE_XLA_CACHE_DIR= $(BIN)/python -m pytest -q -n 2 --dist loadfile -p no:cacheprovider $(ISA_TESTS) \
			|| failed="$$failed $$isa"; \
	done; \
	if [ -n "$$failed" ]; then echo "test-isa: failed under$$failed"; exit 1; fi; \
	echo "test-isa: passed under $(ISA_LEVELS)"

# A coverage-guided fuzz run (atheris) of the one reader of expression text, for FUZZ_SECONDS; it
# fails on any input that is not read or refused in one line within a second (scripts/fuzz_expressions.py),
# and records its numbers in docs/measured/fuzz.json.
FUZZ_SECONDS ?= 600
FUZZ_INSTALLED := $(VENV)/.installed-fuzz
$(FUZZ_INSTALLED): $(INSTALLED)
	$(INSTALL) -e ".[fuzz]"
	touch $(FUZZ_INSTALLED)

fuzz: $(FUZZ_INSTALLED)
	$(BIN)/python scripts/fuzz_expressions.py --record docs/measured/fuzz.json -max_total_time=$(FUZZ_SECONDS)

bench: $(TEST_INSTALLED) $(LLVM_READY) $(RADV_READY) $(NVIDIA_READY) $(INTEL_READY) $(MOBILE_READY)
	$(BIN)/python bench/bench.py

keys: $(INSTALLED)
	$(BIN)/pipeline keys

graph: $(INSTALLED)
	$(BIN)/pipeline graph

# The generated pages (config keys, results.json keys, command help, the README's results table and
# the numbers marked in docs/, from outputs/paper/results.json where it exists), then the site in
# strict mode into docs/_build/.
# The slow runs the pages state (derive runs, the cost tables, example refits, the lobe refits, the
# power regression, the grammar's counts), recorded in docs/measured/ (about 25 minutes; `make docs`
# then fills the pages' numbers from them).
measure: $(INSTALLED) $(LLVM_READY) $(RADV_READY) $(NVIDIA_READY) $(INTEL_READY) $(MOBILE_READY)
	$(BIN)/python scripts/measure.py

docs: $(DOCS_INSTALLED)
	$(BIN)/python scripts/docs.py

clean:
	rm -rf .cache
	find outputs -mindepth 1 -maxdepth 1 ! -name .gitkeep -exec rm -rf {} +
