#!/usr/bin/env bash
# Draws the picture of the module map in docs/architecture.md again from the source (a Mermaid
# flowchart of src/'s folders by layer, with their import arrows); tests/house.rs checks that
# the picture there is the one the source draws.
set -euo pipefail
cd "$(dirname "$0")/.."
WAVETRACE_WRITE_MODULE_MAP=1 cargo test --release --test house the_picture_of_the_house -- --quiet
cargo test --release --test house -- --quiet
