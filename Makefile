# ugpcl: `make run` and `make test` set everything up on a fresh machine (virtualenv, pip packages, PoCL).
PYTHON ?= python3
VENV ?= .venv
UGPCL_DEVICE ?=
SCENE ?= boids
# make mutate (docs/testing.md): the kernel file(s) to mutate (a stem, stems joined by commas, or all), mutants that
# build per file, mutants tested at once (each with the cores / JOBS for PoCL's threads); JSON=path keeps the results.
CHAPTER ?= boids
MUTANTS ?= 15
JOBS ?= 1
# pytest-xdist workers for make test: the suite is mostly one-threaded Python; PoCL's kernels use every core anyway.
# Each test file runs whole on one worker (--dist loadfile), in its own order: the process's one offscreen GL context
# carries state from test to test, and some GL tests fail when another file's tests run between them (seen with
# test_star_glow + test_ear_clipping on two workers: GL_INVALID_OPERATION), which one process never shows.
TEST_WORKERS ?= 2
export UGPCL_DEVICE

BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Debian packages: PoCL (the CPU OpenCL that builds kernels here; PyPI's pocl-binary-distribution cannot, see
# docs/architecture.md, "Devices"), Mesa's EGL/llvmpipe for offscreen PNGs, Xvfb + xdotool for the window test.
SYSTEM_PACKAGES := pocl-opencl-icd ocl-icd-libopencl1 libegl1 libegl-mesa0 libgl1-mesa-dri xvfb xdotool

.DEFAULT_GOAL := help
.PHONY: help system-deps venv run test test-oclgrind test-wheel mutate bench view png anim anim-gpu docs lint clean

help: ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-14s %s\n", $$1, $$2}'

system-deps: ## install PoCL and Mesa EGL with apt-get where they are missing (root), else say what to install
	@command -v dpkg >/dev/null || { echo "make: no dpkg here; install an OpenCL driver (PoCL or a GPU's) and EGL yourself"; exit 0; }; \
	missing=$$(for p in $(SYSTEM_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ]; then \
	  echo "make: apt-get install $$missing"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing >/dev/null; \
	else echo "make: missing Debian packages: $$missing (run: sudo apt-get install $$missing)"; fi

$(STAMP): setup.cfg pyproject.toml
	@$(MAKE) --no-print-directory system-deps
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[all,dev]'
	@touch $@

venv: $(STAMP) ## create .venv/ and install ugpcl (editable) with its test tools

run: $(STAMP) ## headless main job: the book's 16384 boids, 2100 steps (one flock) -> out/boids.npz + out/boids.png
	$(BIN)/ugpcl run boids --steps 2100 --seed 0 --out out/boids.npz --png out/boids.png

test: $(STAMP) ## the test suite on PoCL (CPU), on TEST_WORKERS processes (about 2.5 minutes on 2 cores)
	$(BIN)/pytest -m "not oclgrind" -q -n $(TEST_WORKERS) --dist loadfile --durations=15

test-oclgrind: $(STAMP) ## every kernel on the Oclgrind simulator: data races, out-of-bounds access
	OCLGRIND_DATA_RACES=1 $(BIN)/pytest -m oclgrind -q

mutate: $(STAMP) ## do the tests catch faults put into a kernel file? make mutate CHAPTER=boids MUTANTS=15 JOBS=2
	$(BIN)/python tests/mutate.py --chapter $(CHAPTER) --mutants $(MUTANTS) --jobs $(JOBS) $(if $(JSON),--json $(JSON))

test-wheel: $(STAMP) ## build the wheel, install it in a fresh venv outside the checkout, run scenes from there
	bash .ci/wheel-check

bench: $(STAMP) ## benchmark tables for every chapter on the chosen device
	$(BIN)/ugpcl bench --all

view: $(STAMP) ## open a scene in a window: make view SCENE=boids
	$(BIN)/ugpcl-view $(SCENE)

png: $(STAMP) ## regenerate docs/img/<scene>.png for every scene (offscreen), then the chapter loops (make anim)
	$(BIN)/python -m ugpcl.docs images
	@$(MAKE) --no-print-directory anim

anim: $(STAMP) ## regenerate docs/img/<scene>.webp, the looping animation of each chapter page (offscreen)
	$(BIN)/python -m ugpcl.docs animations

anim-gpu: $(STAMP) ## on a GPU machine: docs/img/gpu/<scene>.webp, the flagship scenes at scale (UGPCL_DEVICE picks the GPU)
	$(BIN)/python -m ugpcl.docs animations --gpu

docs: $(STAMP) ## regenerate the key and parameter tables of docs/chapters/
	$(BIN)/python -m ugpcl.docs tables

lint: $(STAMP) ## ruff check + format check
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

clean: ## remove the virtualenv and outputs
	rm -rf $(VENV) out build dist .pytest_cache .ruff_cache *.egg-info
