#!/bin/sh
# Installs what vlf needs on a fresh Debian/Ubuntu machine, or prints the exact command when it
# cannot (not root). Safe to run again: it only installs what is missing.
#
#   Vulkan loader + Mesa's software Vulkan driver (lavapipe), so GPU code runs without a GPU;
#   Xvfb + xauth + x11-apps + imagemagick, so the viewer's window can be tested headless;
#   Node.js + npm, for Khronos's glTF validator (asset checks) and three.js (web/);
#   chromium, for the browser check of the glTF export (`cargo xtask browser`, headless,
#   software WebGL);
#   a Rust toolchain (rustup) if cargo is missing.
set -eu

need=""
have_pkg() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }
for p in mesa-vulkan-drivers libvulkan1 vulkan-tools xvfb xauth x11-apps imagemagick \
         libegl1 libegl-mesa0 libgl1-mesa-dri libx11-xcb1 libxcursor1 libxi6 libxrandr2 \
         libxkbcommon0 libxkbcommon-x11-0 libwayland-client0 ca-certificates curl; do
    have_pkg "$p" || need="$need $p"
done
command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1 || need="$need nodejs npm"
command -v chromium >/dev/null 2>&1 || need="$need chromium"

if [ -n "$need" ]; then
    if ! command -v apt-get >/dev/null 2>&1; then
        echo "bootstrap: missing packages:$need (and apt-get is not available: install them by hand)" >&2
        exit 1
    fi
    if [ "$(id -u)" -ne 0 ]; then
        echo "bootstrap: missing system packages. Run, then retry:" >&2
        echo "  sudo apt-get update && sudo apt-get install -y --no-install-recommends$need" >&2
        exit 1
    fi
    echo "bootstrap: installing$need"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-install-recommends $need >/dev/null
fi

if ! command -v cargo >/dev/null 2>&1; then
    if [ -x "$HOME/.cargo/bin/cargo" ]; then
        echo "bootstrap: cargo is in ~/.cargo/bin but not on PATH: run  . \"\$HOME/.cargo/env\"" >&2
    else
        echo "bootstrap: no Rust toolchain. Install it with:" >&2
        echo "  curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal -c clippy,rustfmt" >&2
        echo "then  . \"\$HOME/.cargo/env\"  and retry." >&2
    fi
    exit 1
fi
for comp in clippy rustfmt; do
    if ! cargo "$( [ $comp = clippy ] && echo clippy || echo fmt )" --version >/dev/null 2>&1; then
        if command -v rustup >/dev/null 2>&1; then rustup component add "$comp"; else
            echo "bootstrap: cargo $comp missing (rustup component add $comp)" >&2; exit 1; fi
    fi
done
exit 0
