# hapticd: build, run, test and install.
#
#   make run      build hapticd and run it on the simulated SPIDAR-G with the default scene
#   make check    install what the tests need (Debian/Ubuntu packages), then run every test
#   make bench    benchmarks of the per-tick computations (release build)
#   make latency  wake-up latency of the haptic thread against cyclictest (needs SCHED_FIFO)
#   make figures  regenerate the figures shown in docs/
#   make header   regenerate plugin-api/include/hapticd_plugin.h from the Rust ABI
#   make release  build everything make install copies (cargo and a C compiler)
#   make install  install as a distribution would (DESTDIR, PREFIX=/usr, SYSCONFDIR=/etc); no cargo
#   make deb      build the Debian packages hapticd and hapticd-dbgsym into target/deb

CARGO ?= cargo
RELEASE := target/release
# Plugins and descriptors the demonstration and figures use, staged as an install would.
STAGE := target/mechanisms
PLUGINS := hapticd-spidar hapticd-spidar-g hapticd-spidar-ii
HAPTICCTL := $(RELEASE)/hapticctl --mechanism-dir $(STAGE)

# Debian packages the build and tests need beyond Rust itself.
TEST_PACKAGES := gcc libc6-dev make pkg-config libusb-1.0-0-dev umockdev gir1.2-umockdev-1.0 python3-gi strace systemd dbus-daemon iproute2 openssl \
	python3-jeepney python3-pytest python3-pip python3-setuptools python3-numpy \
	dpkg-dev binutils lintian man-db mesa-vulkan-drivers libvulkan1 \
	xvfb libx11-xcb1 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)

.PHONY: run check deps test lint bench latency figures header stage release install deb deb-from-built

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
	$(CARGO) bench -p hapticd-e2e --bench effects
	$(CARGO) bench -p hapticd-e2e --bench joints
	$(CARGO) bench -p hapticd-e2e --bench soft
	$(CARGO) bench -p hapticd-e2e --bench assembly
	$(CARGO) bench -p hapticd-e2e --bench render

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
	$(HAPTICCTL) experiment effects --plot docs/figures/effects.png
	$(HAPTICCTL) experiment pendulum --plot docs/figures/pendulum.png
	$(HAPTICCTL) experiment door --plot docs/figures/door.png
	$(HAPTICCTL) experiment beam --plot docs/figures/beam.png
	$(HAPTICCTL) experiment peg-in-hole --plot docs/figures/peg-in-hole.png
	$(HAPTICCTL) render config/scenes/jelly.yaml --grip 0,-0.012,0 --at 0.5 --out docs/figures/jelly-pressed.png
	$(HAPTICCTL) scene run config/scenes/cube-drop.yaml --duration 2 --model volume --model point \
		--quantity angular-momentum-z --plot docs/figures/cube-drop.png
	$(HAPTICCTL) experiment stack-timing --plot docs/figures/stack-timing.png
	$(HAPTICCTL) experiment stick-slip --plot docs/figures/stick-slip.png
	$(HAPTICCTL) experiment incline --plot docs/figures/incline.png
	$(HAPTICCTL) experiment grasp --plot docs/figures/grasp-shake.png
	$(HAPTICCTL) experiment push-phase --plot docs/figures/push-phase.png
	$(HAPTICCTL) render config/scenes/blocks.yaml --mechanism spidar-g --force 4,12,0 \
		--out docs/figures/render-blocks.png --width 640 --height 400
	$(HAPTICCTL) render config/scenes/balls.yaml --out docs/figures/render-balls.png --width 640 --height 400
	$(HAPTICCTL) render config/scenes/bracket.yaml --out docs/figures/render-bracket.png --width 640 --height 400
	@# The running daemon as hapticctl view shows it: hapticd on the simulated SPIDAR-II, two
	@# fingers in the blocks scene, and hapticd-render beside it, on a bus of their own.
	$(CARGO) build --release -p hapticd-render-service -p hapticd-scene-penalty
	install -m 644 $(RELEASE)/libhapticd_scene_penalty.so $(STAGE)/
	printf 'scene_plugin_dirs: [%s]\n' $(abspath $(STAGE)) > $(STAGE)/figures.yaml
	dbus-run-session -- sh -c '$(RELEASE)/hapticd --bus session --config $(STAGE)/figures.yaml \
		--mechanism-dir $(STAGE) --sim spidar-ii --scene config/scenes/blocks.yaml \
		--hand config/hands/press-blocks.yaml --duration 5 >/dev/null 2>&1 & sleep 1; \
		$(RELEASE)/hapticd-render --bus session 2>/dev/null & sleep 2.5; \
		$(HAPTICCTL) --bus session snapshot docs/figures/snapshot-blocks-spidar-ii.png \
		--width 800 --height 500 --distance 0.55 --elevation 0.7; kill $$!; wait'
	$(HAPTICCTL) scene run config/scenes/top.yaml --duration 12 --model volume --model point \
		--quantity spin --plot docs/figures/spinning-top.png

header:
	HAPTICD_UPDATE_HEADER=1 $(CARGO) test -p hapticd-plugin-api --test c_header

# Installation, laid out as a distribution package would be. `make release` builds (cargo and
# a C compiler); `make install` only copies, so `sudo make install` needs no cargo on root's
# path. BUILT names another build directory (the tests install a debug build). Any PREFIX
# works without rebuilding: hapticd finds its files from where its binary lies
# (daemon/config/src/layout.rs), and its configuration in SYSCONFDIR below.
PREFIX ?= /usr
DEFAULT_SYSCONFDIR := $(if $(filter /usr,$(PREFIX)),/etc,$(PREFIX)/etc)
SYSCONFDIR ?= $(DEFAULT_SYSCONFDIR)
DESTDIR ?=
BUILT ?= $(RELEASE)
# systemd, udev and systemd-sysusers read packages' files under /usr/lib and /usr/local/lib;
# for any other prefix the unit, rules and user go to the administrator's directories in /etc.
SYSTEMLIBDIR ?= $(if $(filter /usr /usr/local,$(PREFIX)),$(PREFIX)/lib,/etc)
# The system bus reads policies from /usr/share/dbus-1/system.d and /etc/dbus-1/system.d only.
DBUSPOLICYDIR ?= $(if $(filter /usr,$(PREFIX)),/usr/share/dbus-1/system.d,/etc/dbus-1/system.d)
MECHANISM_PLUGINS := $(PLUGINS)
SCENE_PLUGINS := hapticd-scene-penalty hapticd-scene-rapier
VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml)
so = $(foreach p,$(1),$(BUILT)/lib$(subst -,_,$(p)).so)
# The C example mechanism, built as a plugin author would build it.
C_MECHANISM := $(BUILT)/libspidar_desk.so
PROGRAMS := hapticd hapticd-render hapticd-zenoh hapticd-world hapticctl
INSTALLED_FILES := $(addprefix $(BUILT)/,$(PROGRAMS)) $(call so,$(MECHANISM_PLUGINS) $(SCENE_PLUGINS))
CONFIG_ARG := $(if $(filter $(DEFAULT_SYSCONFDIR),$(SYSCONFDIR)),, --config $(SYSCONFDIR)/hapticd/hapticd.yaml)
# hapticd-zenoh and hapticd-world look in /etc alone (they have no tree of their own to find a
# prefix from).
BRIDGE_CONFIG_ARG := $(if $(filter /etc,$(SYSCONFDIR)),, --config $(SYSCONFDIR)/hapticd/network.yaml)

release: $(RELEASE)/libspidar_desk.so
	$(CARGO) build --release -p hapticd -p hapticd-render-service -p hapticd-zenoh -p hapticd-world -p hapticctl $(addprefix -p ,$(MECHANISM_PLUGINS) $(SCENE_PLUGINS))

%/libspidar_desk.so: plugins/c-example/spidar_desk.c plugin-api/include/hapticd_plugin.h
	@mkdir -p $(@D)
	$(CC) -shared -fPIC -O2 -g -Wall -Wextra -Werror -std=c11 -fstack-protector-strong \
		-D_FORTIFY_SOURCE=2 -Wl,-z,relro,-z,now -Iplugin-api/include $< -o $@.$$$$ && mv $@.$$$$ $@

install: $(C_MECHANISM)
	@for f in $(INSTALLED_FILES); do [ -e $$f ] || { echo "$$f is not built: run make release first" >&2; exit 1; }; done
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/hapticd/plugins \
		$(DESTDIR)$(PREFIX)/lib/hapticd/scenes $(DESTDIR)$(PREFIX)/include/hapticd \
		$(DESTDIR)$(PREFIX)/share/pkgconfig \
		$(DESTDIR)$(PREFIX)/share/hapticd/mechanisms $(DESTDIR)$(PREFIX)/share/hapticd/scenes/meshes \
		$(DESTDIR)$(PREFIX)/share/hapticd/scenes/textures $(DESTDIR)$(PREFIX)/share/hapticd/scenes/robots \
		$(DESTDIR)$(PREFIX)/share/hapticd/hands $(DESTDIR)$(PREFIX)/share/doc/hapticd/examples \
		$(DESTDIR)$(PREFIX)/share/doc/hapticd/docs/figures \
		$(DESTDIR)$(SYSTEMLIBDIR)/systemd/system $(DESTDIR)$(SYSTEMLIBDIR)/sysusers.d \
		$(DESTDIR)$(SYSTEMLIBDIR)/udev/rules.d $(DESTDIR)$(DBUSPOLICYDIR) \
		$(DESTDIR)$(PREFIX)/share/dbus-1/interfaces \
		$(DESTDIR)$(SYSCONFDIR)/hapticd/mechanisms $(DESTDIR)$(SYSCONFDIR)/hapticd/scenes \
		$(DESTDIR)$(PREFIX)/share/bash-completion/completions $(DESTDIR)$(PREFIX)/share/zsh/vendor-completions \
		$(DESTDIR)$(PREFIX)/share/fish/vendor_completions.d \
		$(DESTDIR)$(PREFIX)/share/man/man1 $(DESTDIR)$(PREFIX)/share/man/man5 $(DESTDIR)$(PREFIX)/share/man/man8
	install -m 755 $(addprefix $(BUILT)/,$(PROGRAMS)) $(DESTDIR)$(PREFIX)/bin/
	$(BUILT)/hapticctl completions bash > $(DESTDIR)$(PREFIX)/share/bash-completion/completions/hapticctl
	$(BUILT)/hapticctl completions zsh > $(DESTDIR)$(PREFIX)/share/zsh/vendor-completions/_hapticctl
	$(BUILT)/hapticctl completions fish > $(DESTDIR)$(PREFIX)/share/fish/vendor_completions.d/hapticctl.fish
	man=$$(mktemp -d) && $(BUILT)/hapticctl manual $$man && \
	for page in $$man/*.[158]; do \
		install -m 644 $$page $(DESTDIR)$(PREFIX)/share/man/man$${page##*.}/; done && rm -r $$man
	install -m 644 $(call so,$(MECHANISM_PLUGINS)) $(C_MECHANISM) $(DESTDIR)$(PREFIX)/lib/hapticd/plugins/
	install -m 644 $(call so,$(SCENE_PLUGINS)) $(DESTDIR)$(PREFIX)/lib/hapticd/scenes/
	install -m 644 plugin-api/include/hapticd_plugin.h $(DESTDIR)$(PREFIX)/include/hapticd/
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@VERSION@|$(VERSION)|' plugin-api/hapticd-plugin.pc.in \
		> $(DESTDIR)$(PREFIX)/share/pkgconfig/hapticd-plugin.pc
	chmod 644 $(DESTDIR)$(PREFIX)/share/pkgconfig/hapticd-plugin.pc
	install -m 644 config/mechanisms/*.yaml $(DESTDIR)$(PREFIX)/share/hapticd/mechanisms/
	install -m 644 config/scenes/*.yaml $(DESTDIR)$(PREFIX)/share/hapticd/scenes/
	install -m 644 config/scenes/meshes/*.obj config/scenes/meshes/*.gltf $(DESTDIR)$(PREFIX)/share/hapticd/scenes/meshes/
	install -m 644 config/scenes/textures/*.png $(DESTDIR)$(PREFIX)/share/hapticd/scenes/textures/
	install -m 644 config/scenes/robots/*.urdf $(DESTDIR)$(PREFIX)/share/hapticd/scenes/robots/
	install -m 644 config/hands/*.yaml $(DESTDIR)$(PREFIX)/share/hapticd/hands/
	install -m 644 README.md LICENSE-MIT LICENSE-APACHE $(DESTDIR)$(PREFIX)/share/doc/hapticd/
	install -m 644 docs/*.md $(DESTDIR)$(PREFIX)/share/doc/hapticd/docs/
	install -m 644 docs/figures/* $(DESTDIR)$(PREFIX)/share/doc/hapticd/docs/figures/
	install -m 644 plugins/c-example/*.c $(DESTDIR)$(PREFIX)/share/doc/hapticd/examples/
	install -m 644 plugins/scene-floor/src/lib.rs $(DESTDIR)$(PREFIX)/share/doc/hapticd/examples/floor_scene.rs
	@# An edited configuration survives a reinstall; the shipped one stays in the documentation.
	for conf in hapticd.yaml network.yaml; do \
		sed -e 's|/etc/hapticd|$(SYSCONFDIR)/hapticd|g' -e 's|/usr/|$(PREFIX)/|g' \
			config/$$conf > $(DESTDIR)$(PREFIX)/share/doc/hapticd/$$conf && \
		chmod 644 $(DESTDIR)$(PREFIX)/share/doc/hapticd/$$conf && \
		if [ -e $(DESTDIR)$(SYSCONFDIR)/hapticd/$$conf ]; then \
			echo "keeping $(DESTDIR)$(SYSCONFDIR)/hapticd/$$conf (shipped: $(PREFIX)/share/doc/hapticd/$$conf)"; \
		else install -m 644 $(DESTDIR)$(PREFIX)/share/doc/hapticd/$$conf $(DESTDIR)$(SYSCONFDIR)/hapticd/; fi || exit 1; \
	done
	for unit in hapticd.service hapticd-guardian.socket hapticd-guardian@.service \
			hapticd-render.service hapticd-zenoh.service hapticd-world.service; do \
		sed -e 's|^ExecStart=/usr/bin/hapticd |ExecStart=$(PREFIX)/bin/hapticd$(CONFIG_ARG) |' \
			-e 's|^ExecStart=@/usr/bin/hapticd |ExecStart=@$(PREFIX)/bin/hapticd |' \
			-e 's|^ExecStart=/usr/bin/hapticd-zenoh |ExecStart=$(PREFIX)/bin/hapticd-zenoh$(BRIDGE_CONFIG_ARG) |' \
			-e 's|^ExecStart=/usr/bin/hapticd-world |ExecStart=$(PREFIX)/bin/hapticd-world$(BRIDGE_CONFIG_ARG) |' \
			-e 's|/etc/hapticd/world.yaml|$(SYSCONFDIR)/hapticd/world.yaml|g' \
			-e 's|^ExecStart=/usr/bin/hapticd-render |ExecStart=$(PREFIX)/bin/hapticd-render |' \
			-e 's|/usr/share/doc/hapticd|$(PREFIX)/share/doc/hapticd|' \
			systemd/$$unit > $(DESTDIR)$(SYSTEMLIBDIR)/systemd/system/$$unit && \
		chmod 644 $(DESTDIR)$(SYSTEMLIBDIR)/systemd/system/$$unit || exit 1; \
	done
	install -m 644 systemd/hapticd.sysusers $(DESTDIR)$(SYSTEMLIBDIR)/sysusers.d/hapticd.conf
	install -m 644 udev/70-hapticd.rules $(DESTDIR)$(SYSTEMLIBDIR)/udev/rules.d/
	install -m 644 config/dbus/org.hapticd.Hapticd1.conf config/dbus/org.hapticd.Renderer1.conf \
		$(DESTDIR)$(DBUSPOLICYDIR)/
	@# No bus activation (docs/operators-guide.md, "Who starts hapticd"): drop the file earlier installs left.
	rm -f $(DESTDIR)$(PREFIX)/share/dbus-1/system-services/org.hapticd.Hapticd1.service
	install -m 644 config/dbus/org.hapticd.Hapticd1.Manager.xml config/dbus/org.hapticd.Hapticd1.Device.xml \
		config/dbus/org.hapticd.Hapticd1.Scene.xml config/dbus/org.hapticd.Renderer1.xml \
		$(DESTDIR)$(PREFIX)/share/dbus-1/interfaces/

# The Debian packages, from a tree installed under /usr (config/debian/build-deb strips it,
# splits the debug information off and writes the control files). deb-from-built packages
# BUILT as it is (the tests package a debug build into their own DEB).
DEB ?= target/deb
deb: release
	$(MAKE) --no-print-directory deb-from-built BUILT=$(RELEASE)

deb-from-built:
	rm -rf $(DEB) && mkdir -p $(DEB)/root
	$(MAKE) --no-print-directory -s install DESTDIR=$(abspath $(DEB)/root) PREFIX=/usr SYSCONFDIR=/etc BUILT=$(BUILT)
	config/debian/build-deb $(DEB)/root $(DEB)
