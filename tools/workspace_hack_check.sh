#!/usr/bin/env bash
# Lists the crates that the Python wheel's build (`foosball-py` alone, as maturin builds it)
# would compile with other features than CI's workspace build (`--workspace --features
# vulkan`), which makes CI's wheel phase compile them again. Empty output: the wheel reuses
# every shared crate. Fix a line by adding its features to crates/workspace-hack/Cargo.toml
# (target crates under [dependencies], proc-macro and build-script crates under
# [build-dependencies]). Needs no build: `cargo tree` only.
set -euo pipefail
cd "$(dirname "$0")/.."
units() { cargo tree --locked "$@" -f '{p}|{f}' --prefix none 2>/dev/null | sed 's/ (\*)$//' | grep -v '^foosball' | sort -u; }
ws=$(mktemp); py=$(mktemp); trap 'rm -f "$ws" "$py"' EXIT
for edges in normal,no-proc-macro normal,build; do
    units --workspace --features vulkan -e "$edges" > "$ws"
    units -p foosball-py -e "$edges" > "$py"
    comm -23 "$py" "$ws" | sed "s/^/wheel-only features ($edges): /"
done
