#!/usr/bin/env bash
# Sets up, builds, writes the bundled cloud sample's lit VDB and prints the bake summary.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)"
mkdir -p out
./build/vdbscatter bake --scene samples/cloud.json -o out/cloud_lit.vdb --report out/cloud_lit.json
./build/vdbscatter info out/cloud_lit.vdb
