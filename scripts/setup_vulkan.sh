#!/usr/bin/env bash
# Make sure SAPIEN can find a Vulkan rendering device.
#
# Usage: scripts/setup_vulkan.sh PYTHON
#   PYTHON is an interpreter that has sapien installed (the project's .venv).
#
# If a usable device exists, this does nothing. On Debian bookworm without one it installs Mesa's
# lavapipe (software Vulkan) from bookworm-backports, reusing the Debian mirror this machine already
# has configured. Anywhere else it prints what to install and exits non-zero.
set -euo pipefail

python=${1:?usage: setup_vulkan.sh PYTHON}
check() { "$python" -m robolab_ms.render_check "$@"; }

if check --quiet; then
    exit 0
fi

. /etc/os-release 2>/dev/null || true
if [ "${ID:-}" != "debian" ] || [ "${VERSION_CODENAME:-}" != "bookworm" ]; then
    check || true
    echo "No Vulkan device usable by SAPIEN. On this system (${PRETTY_NAME:-unknown}) install a Vulkan driver" >&2
    echo "yourself: an NVIDIA driver on a GPU machine, or Mesa >= 24 'mesa-vulkan-drivers' + 'libvulkan1' for CPU rendering." >&2
    exit 1
fi

sudo=""
if [ "$(id -u)" != 0 ]; then
    if command -v sudo >/dev/null; then sudo="sudo"; else
        echo "Installing lavapipe needs root: rerun as root or install sudo." >&2; exit 1
    fi
fi

# Find the Debian mirror already configured for bookworm (deb822 .sources first, then one-line lists).
mirror=""
for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    mirror=$(awk '
        /^URIs:/   { uris = $2 }
        /^Suites:/ { for (i = 2; i <= NF; i++) if ($i == "bookworm") ok = 1 }
        /^$/       { if (ok && uris != "") { print uris; exit } uris = ""; ok = 0 }
        END        { if (ok && uris != "") print uris }' "$f" | head -n1)
    [ -n "$mirror" ] && break
done
if [ -z "$mirror" ]; then
    mirror=$(cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null \
        | awk '$1 == "deb" && $0 ~ / bookworm / { for (i = 2; i <= NF; i++) if ($i ~ /^[a-z]+:\/\//) { print $i; exit } }')
fi
if [ -z "$mirror" ]; then
    echo "Could not find the Debian mirror for bookworm in /etc/apt; add bookworm-backports yourself and" >&2
    echo "install mesa-vulkan-drivers and libvulkan1 from it." >&2
    exit 1
fi

list=/etc/apt/sources.list.d/robolab-ms-backports.list
echo "No usable Vulkan device: installing Mesa lavapipe from bookworm-backports ($list)"
echo "deb $mirror bookworm-backports main" | $sudo tee "$list" >/dev/null
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers libvulkan1 >/dev/null

check
