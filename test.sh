#!/usr/bin/env bash
# The whole test suite: Rust (`cargo test`: unit, property, integration, doc) and Python
# (the `trimorph` package installed by pip into a virtual environment, then pytest).
# Extra arguments go to `cargo test`. Needs Rust and Python >= 3.9 with venv; the Python
# packages come from PyPI on the first run (then cached in target/venv).
set -euo pipefail
cd "$(dirname "$0")"

echo "== [$(date -u +%T)] cargo test"
# `--workspace` resolves the dependencies' features as for the whole workspace, the Python
# bindings' included (they have no Rust tests of their own), so the extension's build below
# reuses these dependency builds instead of building about 90 of them again.
cargo test --workspace "$@"

echo "== [$(date -u +%T)] python: pip install ./python[test], then pytest python/tests"
VENV="${TRIMORPH_VENV:-target/venv}"
PYTHON="${PYTHON:-python3}"
[ -x "$VENV/bin/python" ] || "$PYTHON" -m venv "$VENV"
# The extension (a member of this workspace) builds in the dev profile and in the
# workspace's target folder, with the library's default features (`trimorph/default`, the
# set `cargo test` built it with), so every dependency and the library itself come from
# the test build above: only PyO3 and the bindings compile here. A release build of
# everything took a third of the suite's time. `pip install ./python` outside this script
# builds a release wheel without the command line's features.
export CARGO_TARGET_DIR="$PWD/target"
MATURIN_PEP517_ARGS="--profile dev --features trimorph/default" \
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "./python[test]"
# Two workers (pytest-xdist): a single pytest process kept CI's second core idle for much of
# its four minutes. The slowest tests are listed at the end.
TRIMORPH_BIN="$PWD/target/debug/trimorph" "$VENV/bin/python" -m pytest -q -n 2 --durations=10 python/tests

# The napari plugin (napari/), installed after the package it wraps; its own pytest run, as
# both test folders have a conftest.py. Its viewer tests need an X server: a private Xvfb
# is started when there is no display (apt-get install xvfb), else they are skipped.
echo "== [$(date -u +%T)] napari plugin: pip install ./napari[test], then pytest napari/tests"
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "./napari[test]"
"$VENV/bin/python" -m pytest -q napari/tests
