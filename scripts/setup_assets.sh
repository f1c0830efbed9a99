#!/usr/bin/env bash
# Install the assets that do not come through pip: the HDR environment maps of the npm package @pmndrs/assets
# (CC0-1.0), decoded into the virtual environment (share/robolab_ms/hdri), and the lighting maps made from them
# (the cache folder). Idempotent: does nothing when they are there. The object meshes and the table and floor
# textures are pip packages pinned in requirements.lock.
#
# Usage: scripts/setup_assets.sh PYTHON      (PYTHON: the project's .venv interpreter)
# Needs npm (Debian: apt-get install npm) only when the maps are missing.
set -euo pipefail

python=${1:?usage: setup_assets.sh PYTHON}
PMNDRS_VERSION=1.7.0

lighting_maps() {  # the scaled, downsampled lighting maps (else each is made at first use); needs a render device
    "$python" -m robolab_ms.scene.backgrounds lighting >/dev/null 2>&1 || true
}

if "$python" -m robolab_ms.scene.backgrounds check 2>/dev/null; then
    lighting_maps
    exit 0
fi
if ! command -v npm >/dev/null; then
    echo "The HDR backgrounds need npm to fetch @pmndrs/assets@$PMNDRS_VERSION: install npm (Debian: apt-get install npm)" >&2
    echo "and rerun 'make setup'. Scenes that name no background work without them." >&2
    exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
(cd "$work" && npm pack --silent "@pmndrs/assets@$PMNDRS_VERSION" >/dev/null)
"$python" -m robolab_ms.scene.backgrounds unpack "$work"/pmndrs-assets-"$PMNDRS_VERSION".tgz
lighting_maps
