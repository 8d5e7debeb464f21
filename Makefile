# hapticd: build, run, test and install.
#
#   make run      build hapticd and run it on the simulated SPIDAR-G with the default scene
#   make check    install what the tests need (Debian/Ubuntu packages), then run every test
#   make bench    benchmarks of the per-tick computations (release build)
#   make latency  wake-up latency of the haptic thread against cyclictest (needs SCHED_FIFO)
#   make figures  regenerate the figures shown in the README
#   make header   regenerate plugin-api/include/hapticd_plugin.h from the Rust ABI
#   make install  install as a distribution would (DESTDIR, PREFIX=/usr, SYSCONFDIR=/etc)

CARGO ?= cargo
RELEASE := target/release
# Plugins and descriptors the demonstration and figures use, staged as an install would.
STAGE := target/mechanisms
PLUGINS := hapticd-spidar hapticd-spidar-g hapticd-spidar-ii
HAPTICCTL := $(RELEASE)/hapticctl --mechanism-dir $(STAGE)

# Debian packages the build and tests need beyond Rust itself.
TEST_PACKAGES := gcc libc6-dev make pkg-config libusb-1.0-0-dev umockdev gir1.2-umockdev-1.0 python3-gi strace systemd dbus-daemon
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: run check deps test lint bench latency figures header stage release install

stage:
	$(CARGO) build --release -p hapticd -p hapticctl $(addprefix -p ,$(PLUGINS))
	rm -rf $(STAGE) && install -d -m 755 $(STAGE)
	install -m 644 $(foreach p,$(PLUGINS),$(RELEASE)/lib$(subst -,_,$(p)).so) config/mechanisms/*.yaml $(STAGE)/

# The simulated hand lowers the grip onto the floor, presses, slides and lifts off; the
# status lines show the floor holding it at y = -0.03 m and the force it feels.
run: stage
	$(RELEASE)/hapticd --mechanism-dir $(STAGE) --sim spidar-g \
		--scene config/scenes/static.yaml --hand config/hands/press-floor.yaml --duration 4

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
	$(CARGO) bench -p hapticd-e2e --bench mechanism
	$(CARGO) bench -p hapticd-e2e --bench physics

latency:
	@command -v cyclictest >/dev/null || $(SUDO) apt-get install -y -q --no-install-recommends rt-tests
	$(CARGO) build --release --workspace
	$(CARGO) bench -p hapticd-e2e --bench latency

figures: stage
	$(HAPTICCTL) mechanism sweep spidar --plot docs/figures/tension-sweep-spidar.png
	$(HAPTICCTL) mechanism workspace spidar-g --plot docs/figures/workspace-spidar-g.png
	$(HAPTICCTL) mechanism workspace spidar --plot docs/figures/workspace-spidar.png
	$(HAPTICCTL) experiment stiffness spidar --plot docs/figures/wall-stiffness.png
	$(HAPTICCTL) experiment cylinder --plot docs/figures/cylinder-tracing.png
	$(HAPTICCTL) scene run config/scenes/cube-drop.yaml --duration 2 --model volume --model point \
		--quantity angular-momentum-z --plot docs/figures/cube-drop.png
	$(HAPTICCTL) experiment stack-timing --plot docs/figures/stack-timing.png
	$(HAPTICCTL) experiment stick-slip --plot docs/figures/stick-slip.png
	$(HAPTICCTL) scene run config/scenes/top.yaml --duration 12 --model volume --model point \
		--quantity spin --plot docs/figures/spinning-top.png

header:
	HAPTICD_UPDATE_HEADER=1 $(CARGO) test -p hapticd-plugin-api --test c_header

# Installation, laid out as a distribution package would be. `make install` builds the
# release binaries first; BUILT names another build directory (the tests install a debug build).
PREFIX ?= /usr
SYSCONFDIR ?= /etc
DESTDIR ?=
BUILT ?= $(RELEASE)
MECHANISM_PLUGINS := $(PLUGINS)
SCENE_PLUGINS := hapticd-scene-penalty
so = $(foreach p,$(1),$(BUILT)/lib$(subst -,_,$(p)).so)

release:
	$(CARGO) build --release -p hapticd -p hapticctl $(addprefix -p ,$(MECHANISM_PLUGINS) $(SCENE_PLUGINS))

install: release
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/hapticd/plugins \
		$(DESTDIR)$(PREFIX)/lib/hapticd/scenes $(DESTDIR)$(PREFIX)/include \
		$(DESTDIR)$(PREFIX)/share/hapticd/mechanisms $(DESTDIR)$(PREFIX)/share/hapticd/scenes \
		$(DESTDIR)$(PREFIX)/share/hapticd/hands $(DESTDIR)$(PREFIX)/share/doc/hapticd \
		$(DESTDIR)$(PREFIX)/lib/systemd/system $(DESTDIR)$(PREFIX)/lib/sysusers.d \
		$(DESTDIR)$(PREFIX)/lib/udev/rules.d $(DESTDIR)$(PREFIX)/share/dbus-1/system.d \
		$(DESTDIR)$(PREFIX)/share/dbus-1/system-services $(DESTDIR)$(PREFIX)/share/dbus-1/interfaces \
		$(DESTDIR)$(SYSCONFDIR)/hapticd/mechanisms $(DESTDIR)$(SYSCONFDIR)/hapticd/scenes \
		$(DESTDIR)$(PREFIX)/share/bash-completion/completions $(DESTDIR)$(PREFIX)/share/zsh/vendor-completions \
		$(DESTDIR)$(PREFIX)/share/fish/vendor_completions.d
	install -m 755 $(BUILT)/hapticd $(BUILT)/hapticctl $(DESTDIR)$(PREFIX)/bin/
	$(BUILT)/hapticctl completions bash > $(DESTDIR)$(PREFIX)/share/bash-completion/completions/hapticctl
	$(BUILT)/hapticctl completions zsh > $(DESTDIR)$(PREFIX)/share/zsh/vendor-completions/_hapticctl
	$(BUILT)/hapticctl completions fish > $(DESTDIR)$(PREFIX)/share/fish/vendor_completions.d/hapticctl.fish
	install -m 644 $(call so,$(MECHANISM_PLUGINS)) $(DESTDIR)$(PREFIX)/lib/hapticd/plugins/
	install -m 644 $(call so,$(SCENE_PLUGINS)) $(DESTDIR)$(PREFIX)/lib/hapticd/scenes/
	install -m 644 plugin-api/include/hapticd_plugin.h $(DESTDIR)$(PREFIX)/include/
	install -m 644 config/mechanisms/*.yaml $(DESTDIR)$(PREFIX)/share/hapticd/mechanisms/
	install -m 644 config/scenes/*.yaml $(DESTDIR)$(PREFIX)/share/hapticd/scenes/
	install -m 644 config/hands/*.yaml $(DESTDIR)$(PREFIX)/share/hapticd/hands/
	install -m 644 README.md $(DESTDIR)$(PREFIX)/share/doc/hapticd/
	install -m 644 config/hapticd.yaml $(DESTDIR)$(SYSCONFDIR)/hapticd/
	install -m 644 systemd/hapticd.service $(DESTDIR)$(PREFIX)/lib/systemd/system/
	install -m 644 systemd/hapticd.sysusers $(DESTDIR)$(PREFIX)/lib/sysusers.d/hapticd.conf
	install -m 644 udev/70-hapticd.rules $(DESTDIR)$(PREFIX)/lib/udev/rules.d/
	install -m 644 config/dbus/org.hapticd.Hapticd1.conf $(DESTDIR)$(PREFIX)/share/dbus-1/system.d/
	install -m 644 systemd/org.hapticd.Hapticd1.service $(DESTDIR)$(PREFIX)/share/dbus-1/system-services/
	install -m 644 config/dbus/org.hapticd.Hapticd1.Manager.xml config/dbus/org.hapticd.Hapticd1.Device.xml \
		$(DESTDIR)$(PREFIX)/share/dbus-1/interfaces/
