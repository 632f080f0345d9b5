# Sourced by the scripts: create .venv on first use, reinstall only when pyproject.toml changes.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
PY="${PYTHON:-python3}"
STAMP="$VENV/.sonarmorph-installed"
if [ ! -x "$VENV/bin/python" ]; then
    echo "==> creating $VENV" >&2
    "$PY" -m venv "$VENV"
    "$VENV/bin/python" -m pip install --quiet --upgrade pip >&2
fi
want="$(sha256sum "$ROOT/pyproject.toml" | cut -d' ' -f1)${EXTRAS:-test}"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$want" ]; then
    echo "==> installing sonarmorph[${EXTRAS:-test}] into $VENV" >&2
    install_log="$VENV/.install.log"
    if ! "$VENV/bin/python" -m pip install --quiet -e "$ROOT[${EXTRAS:-test}]" >"$install_log" 2>&1; then
        cat "$install_log" >&2
        echo "==> installing sonarmorph failed (log: $install_log)" >&2
        exit 1
    fi
    echo "$want" > "$STAMP"
fi
export PATH="$VENV/bin:$PATH"
cd "$ROOT"
