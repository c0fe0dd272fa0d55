#!/usr/bin/env bash
# Lists the dependency units the Python wheel (maturin builds python/ alone) would compile that
# `cargo test --workspace` does not already build, i.e. where python/Cargo.toml's feature pins are
# stale. Needs a nightly toolchain for `--unit-graph` (it only resolves; nothing is compiled).
# Exit 1 when a unit differs.
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cargo +nightly test --workspace --no-run --unit-graph -Z unstable-options >"$tmp/ws.json"
cargo +nightly build -p robosim-python --lib --unit-graph -Z unstable-options >"$tmp/py.json"
python3 tools/wheel_units_diff.py "$tmp/ws.json" "$tmp/py.json"
