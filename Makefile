# hapticd: build, run, test and install.
#
#   make run      build and run the demonstration on the shipped mechanisms
#   make check    install what the tests need (Debian/Ubuntu packages), then run every test
#   make bench    benchmarks of the per-tick computations (release build)
#   make figures  regenerate the figures shown in the README
#   make header   regenerate plugin-api/include/hapticd_plugin.h from the Rust ABI

CARGO ?= cargo
RELEASE := target/release
# Plugins and descriptors the demonstration and figures use, staged as an install would.
STAGE := target/mechanisms
PLUGINS := hapticd-spidar hapticd-spidar-g hapticd-spidar-ii
HAPTICCTL := $(RELEASE)/hapticctl --mechanism-dir $(STAGE)

# Debian packages the build and tests need beyond Rust itself.
TEST_PACKAGES := gcc libc6-dev make
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: run check deps test lint bench figures header stage

stage:
	$(CARGO) build --release -p hapticd $(addprefix -p ,$(PLUGINS))
	rm -rf $(STAGE) && install -d -m 755 $(STAGE)
	install -m 644 $(foreach p,$(PLUGINS),$(RELEASE)/lib$(subst -,_,$(p)).so) config/mechanisms/*.yaml $(STAGE)/

run: stage
	$(HAPTICCTL) mechanism list
	$(HAPTICCTL) mechanism inspect spidar-g
	$(HAPTICCTL) mechanism pose spidar --lengths 0.459,0.459,0.459,0.459
	$(HAPTICCTL) mechanism tension spidar-g --position 0.01,0,0 --force 0,-3,0 --torque 0,0,0.02
	$(HAPTICCTL) mechanism sweep spidar --plot target/sweep.png
	$(HAPTICCTL) mechanism workspace spidar-g --plot target/workspace.png

deps:
	@missing=$$(for p in $(TEST_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
		echo "installing: $$missing"; \
		$(SUDO) apt-get update -q && $(SUDO) apt-get install -y -q --no-install-recommends $$missing; \
	fi

test:
	$(CARGO) build --workspace --all-targets
	$(CARGO) test --workspace

lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

check: deps lint test

bench:
	$(CARGO) build --release --workspace
	$(CARGO) bench -p hapticd-e2e

figures: stage
	$(HAPTICCTL) mechanism sweep spidar --plot docs/figures/tension-sweep-spidar.png
	$(HAPTICCTL) mechanism workspace spidar-g --plot docs/figures/workspace-spidar-g.png
	$(HAPTICCTL) mechanism workspace spidar --plot docs/figures/workspace-spidar.png

header:
	HAPTICD_UPDATE_HEADER=1 $(CARGO) test -p hapticd-plugin-api --test c_header
