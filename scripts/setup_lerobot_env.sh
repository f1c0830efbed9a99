#!/usr/bin/env bash
# Builds (or reuses) the Python 3.12 environment that runs LeRobot policy servers, from requirements-lerobot.lock.
#
#   scripts/setup_lerobot_env.sh                 build or reuse it; prints its python on the last line
#   scripts/setup_lerobot_env.sh --find-python   print the Python 3.12 interpreter it would use (exit 3: none)
#
# The environment lives outside the checkout, so every clone on a machine shares one:
#   $ROBOLAB_LEROBOT_ENV, else lerobot-env in robolab_ms's cache folder ($ROBOLAB_MS_CACHE, else
#   $XDG_CACHE_HOME/robolab_ms, else ~/.cache/robolab_ms)
# and the checkout gets a link to it, .venv-lerobot. It is reused while it was built from the current lock file
# (its sha256 is kept in the environment); after the lock changes, the pins are installed into it again.
# The interpreter: $ROBOLAB_LEROBOT_PYTHON, else `python3.12` on PATH, else pyenv's 3.12 (PYENV_ROOT or ~/.pyenv).
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
lock="$repo/requirements-lerobot.lock"
cache=${ROBOLAB_MS_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/robolab_ms}
env_dir=${ROBOLAB_LEROBOT_ENV:-$cache/lerobot-env}

is_python312() {
    "$1" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 12))' >/dev/null 2>&1
}

find_python() {
    local candidate
    if [ -n "${ROBOLAB_LEROBOT_PYTHON:-}" ]; then
        if is_python312 "$ROBOLAB_LEROBOT_PYTHON"; then echo "$ROBOLAB_LEROBOT_PYTHON"; return 0; fi
        echo "ROBOLAB_LEROBOT_PYTHON=$ROBOLAB_LEROBOT_PYTHON is not a working Python 3.12" >&2
        return 3
    fi
    for candidate in python3.12 "${PYENV_ROOT:-$HOME/.pyenv}"/versions/3.12*/bin/python3.12; do
        if is_python312 "$candidate"; then command -v "$candidate"; return 0; fi
    done
    echo "no Python 3.12 found (LeRobot needs it): install one (e.g. \`pyenv install 3.12\` or your system's" \
         "python3.12 package) or set ROBOLAB_LEROBOT_PYTHON to its path" >&2
    return 3
}

if [ "${1:-}" = "--find-python" ]; then
    find_python
    exit
fi

python=$(find_python) || exit 3
mkdir -p "$(dirname "$env_dir")"
exec 9>"$env_dir.building"
flock 9  # one build at a time; a second caller waits, then reuses

want=$(sha256sum "$lock" | cut -d' ' -f1)
stamp="$env_dir/.lock-sha256"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && "$env_dir/bin/python" -c "import lerobot" 2>/dev/null; then
    echo "LeRobot environment up to date: $env_dir" >&2
else
    echo "building the LeRobot environment in $env_dir with $python (the first build downloads about 3 GB)" >&2
    start=$(date +%s)
    if ! is_python312 "$env_dir/bin/python"; then
        if [ -e "$env_dir" ] && [ ! -f "$env_dir/pyvenv.cfg" ] && [ -n "$(ls -A "$env_dir")" ]; then
            echo "$env_dir exists and is not a Python environment: move it away or set ROBOLAB_LEROBOT_ENV" >&2
            exit 2
        fi
        rm -rf "$env_dir"  # empty, or an environment of another Python
        "$python" -m venv "$env_dir"
    fi
    rm -f "$stamp"
    "$env_dir/bin/python" -m pip install --quiet --upgrade "pip>=24"
    "$env_dir/bin/python" -m pip install --quiet -r "$lock"
    "$env_dir/bin/python" -m pip check >&2
    echo "$want" >"$stamp"
    echo "built in $(($(date +%s) - start)) s, $(du -sh "$env_dir" | cut -f1)" >&2
fi
ln -sfn "$env_dir" "$repo/.venv-lerobot"
echo "$env_dir/bin/python"
