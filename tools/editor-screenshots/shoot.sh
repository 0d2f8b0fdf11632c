#!/usr/bin/env bash
# Regenerates the README's editor screenshots (docs/images/editor_*.png): drives `tessera lsp`
# over stdio as an editor would (drive.mjs records its diagnostics, hover and completions and
# the TextMate grammar's tokens of the text), then shows those answers in Monaco, VS Code's
# editor component, and screenshots it with headless Chromium.
#
# Needs node, npm and chromium; usage: tools/editor-screenshots/shoot.sh [path/to/tessera]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
bin="$(realpath "${1:-$repo/target/release/tessera}")"
work="$(mktemp -d)"
trap 'kill $server 2>/dev/null || true; rm -rf "$work"' EXIT
cp "$here/drive.mjs" "$here/page.html" "$work/"
mkdir "$work/proj"
cp -r "$repo/tessera.toml" "$repo/scenes" "$repo/samples" "$work/proj/"
cd "$work"
npm install --silent --no-save --no-package-lock --no-audit --no-fund \
  monaco-editor@0.52.0 vscode-oniguruma@2.0.1 vscode-textmate@9.4.0
node drive.mjs "$bin" proj scenes/noise_tiling.tess "$repo/editors/textmate/tessera.tmLanguage.json" data.json
python3 -m http.server 8765 --bind 127.0.0.1 >/dev/null 2>&1 &
server=$!
sleep 1
for mode in diag hover complete; do
  chromium --headless=old --no-sandbox --disable-gpu --hide-scrollbars --window-size=1000,480 \
    --virtual-time-budget=6000 --screenshot="$repo/docs/images/editor_$mode.png" \
    "http://127.0.0.1:8765/page.html?mode=$mode" 2>/dev/null
done
