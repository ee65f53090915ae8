#!/usr/bin/env bash
# README Quick start command 1: install dependencies, build, make the built-in demo dataset and describe it.
# (Later this ends in the interactive viewer.)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
ninja -C build ugvr
mkdir -p out
./build/ugvr generate --cells 200000 --kind mixed -o out/demo.vtu
./build/ugvr info out/demo.vtu
