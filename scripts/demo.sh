#!/usr/bin/env bash
# Sets up, builds, bakes the bundled cloud sample into a lit VDB and renders it to a PNG.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)"
mkdir -p out
./build/vdbscatter bake --scene samples/cloud.json -o out/cloud_lit.vdb --report out/cloud_lit.json
./build/vdbscatter render out/cloud_lit.vdb -o out/cloud.png
echo "wrote out/cloud_lit.vdb (lit VDB), out/cloud_lit.json (bake report) and out/cloud.png"
