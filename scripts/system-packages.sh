#!/usr/bin/env bash
# Debian packages the test suite needs beyond Python (a database server, a browser): installed when missing,
# so that a fresh machine or CI runs those tests instead of skipping them. Needs root (CI and the dev
# machines run as root); elsewhere it says what to install and carries on, and the tests that need a
# missing program skip with that reason.
set -euo pipefail

# One line per package: the program it provides (checked on PATH or as a path) and the Debian package.
NEEDED=(
    # PostgreSQL server (initdb, pg_ctl): tests/utils/postgres_server.py starts one in a temp folder
    /usr/lib/postgresql/15/bin/initdb:postgresql
    # headless Chromium and its WebDriver: the dashboard's browser tests (tests/service/test_ui_browser.py)
    chromium:chromium
    chromedriver:chromium-driver
)

missing=()
for entry in "${NEEDED[@]}"; do
    program="${entry%%:*}"
    package="${entry#*:}"
    if ! command -v "$program" >/dev/null 2>&1 && [ ! -x "$program" ]; then
        missing+=("$package")
    fi
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
    echo "system-packages: not root; install these for the full test suite: ${missing[*]}" >&2
    exit 0
fi
echo "system-packages: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq >/dev/null
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
