#!/bin/sh
# Make sure the browser tests can run: Debian's chromium and the npm packages playwright-core
# and axe-core (pinned in package-lock.json). Installs only what is missing; safe to run again.
# Exit status 0 when both are ready, 1 with a one-line reason otherwise.
set -u
here=$(cd "$(dirname "$0")" && pwd)

if ! command -v chromium >/dev/null 2>&1; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
        export DEBIAN_FRONTEND=noninteractive
        (apt-get update -qq && apt-get install -y -qq --no-install-recommends chromium) \
            >"${TMPDIR:-/tmp}/morphogen-chromium-install.log" 2>&1
    fi
fi
if ! command -v chromium >/dev/null 2>&1; then
    echo "chromium is not installed and could not be installed with apt-get"
    exit 1
fi

if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    echo "node and npm are needed to drive the browser (playwright-core)"
    exit 1
fi
if [ ! -f "$here/node_modules/playwright-core/package.json" ] || [ ! -f "$here/node_modules/axe-core/axe.min.js" ]; then
    (cd "$here" && NPM_CONFIG_UPDATE_NOTIFIER=false npm ci --no-audit --no-fund --loglevel=error) \
        >"${TMPDIR:-/tmp}/morphogen-playwright-install.log" 2>&1 || {
        echo "npm could not install playwright-core and axe-core (see ${TMPDIR:-/tmp}/morphogen-playwright-install.log)"
        exit 1
    }
fi
exit 0
