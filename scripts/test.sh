#!/usr/bin/env bash
# The whole test suite: Rust formatting, lints and tests, Python lints and tests.
# Run after the install command in README.md (the package must be installed).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --all -- --check
cargo clippy --workspace --all-targets -- -D warnings
cargo test -p vibroimpact-core
ruff check python tests benchmarks examples
python -m pytest -q
