#!/usr/bin/env bash
# The whole test suite: Rust (`cargo test`: unit, property, integration, doc) and Python
# (the `trimorph` package installed by pip into a virtual environment, then pytest).
# Extra arguments go to `cargo test`. Needs Rust and Python >= 3.9 with venv; the Python
# packages come from PyPI on the first run (then cached in target/venv).
set -euo pipefail
cd "$(dirname "$0")"

echo "== [$(date -u +%T)] cargo test"
cargo test "$@"

echo "== [$(date -u +%T)] python: pip install ./python[test], then pytest python/tests"
VENV="${TRIMORPH_VENV:-target/venv}"
PYTHON="${PYTHON:-python3}"
[ -x "$VENV/bin/python" ] || "$PYTHON" -m venv "$VENV"
# The extension (a member of this workspace) builds in the dev profile (dependencies at
# opt-level 2, as for `cargo test`) and in the workspace's target folder, so the dependency
# builds the two share are reused; a release build of everything took a third of the suite's
# time. `pip install ./python` outside this script builds in release mode.
export CARGO_TARGET_DIR="$PWD/target"
MATURIN_PEP517_ARGS="--profile dev" \
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "./python[test]"
TRIMORPH_BIN="$PWD/target/debug/trimorph" "$VENV/bin/python" -m pytest -q python/tests

# The napari plugin (napari/), installed after the package it wraps; its own pytest run, as
# both test folders have a conftest.py. Its viewer tests need an X server: a private Xvfb
# is started when there is no display (apt-get install xvfb), else they are skipped.
echo "== [$(date -u +%T)] napari plugin: pip install ./napari[test], then pytest napari/tests"
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "./napari[test]"
"$VENV/bin/python" -m pytest -q napari/tests
