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
# Reinstall only when pyproject.toml changed or an extra we need is missing, so that
# ./scripts/bench (test,bench) and ./scripts/test (test,live) do not undo each other.
want_extras="${EXTRAS:-test,live}"
hash="$(sha256sum "$ROOT/pyproject.toml" | cut -d' ' -f1)"
have_hash="" have_extras=""
[ -f "$STAMP" ] && read -r have_hash have_extras < "$STAMP" || true
need_install=0
[ "$have_hash" = "$hash" ] || need_install=1
for extra in ${want_extras//,/ }; do
    case ",$have_extras," in *",$extra,"*) ;; *) need_install=1 ;; esac
done
if [ "$need_install" = 1 ]; then
    [ "$have_hash" = "$hash" ] && [ -n "$have_extras" ] && want_extras="$have_extras,$want_extras"
    echo "==> installing sonarmorph[$want_extras] into $VENV" >&2
    install_log="$VENV/.install.log"
    if ! "$VENV/bin/python" -m pip install --quiet -e "$ROOT[$want_extras]" >"$install_log" 2>&1; then
        cat "$install_log" >&2
        echo "==> installing sonarmorph failed (log: $install_log)" >&2
        exit 1
    fi
    echo "$hash $want_extras" > "$STAMP"
fi
export PATH="$VENV/bin:$PATH"
cd "$ROOT"
