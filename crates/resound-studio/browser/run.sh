#!/usr/bin/env bash
# Resound Studio's browser tests: headless Debian chromium driven by playwright-core (npm,
# pinned in package-lock.json; it uses the system browser and downloads none). Installs what
# is missing, then runs test.mjs against the debug `resound` that `cargo test` built. Screenshots
# go to target/studio-screenshots/. From any directory.
set -euo pipefail
cd "$(dirname "$0")/../../.."
if ! command -v chromium >/dev/null 2>&1; then
    (apt-get install -y chromium >/dev/null 2>&1 \
        || (apt-get update -qq >/dev/null 2>&1 && apt-get install -y chromium >/dev/null 2>&1) \
        || sudo apt-get install -y chromium >/dev/null 2>&1) \
        || { echo "error: the browser tests need Debian's chromium (apt-get install chromium)" >&2; exit 1; }
fi
B=crates/resound-studio/browser
[ -d "$B/node_modules/playwright-core" ] || (cd "$B" && npm ci --silent --no-audit --no-fund)
[ -x target/debug/resound ] || cargo build --quiet -p resound-cli
node "$B/test.mjs" target/debug/resound target/studio-screenshots
