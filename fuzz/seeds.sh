#!/usr/bin/env bash
# Fills each target's seed corpus from the test data, once (small files only).
set -euo pipefail
cd "$(dirname "$0")"
data=../tests/data
seed() { # target, files...
  local t=$1; shift
  [ -n "$(ls -A "corpus/$t" 2>/dev/null)" ] && return 0
  mkdir -p "corpus/$t"
  for f in "$@"; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 65536 ] && cp "$f" "corpus/$t/$(basename "$f")"
  done
  true
}
seed ply $(find "$data/ply-corpus" -name '*.ply' -size -64k | head -60)
seed obj $(find "$data" ../content -name '*.obj' -size -64k | head -20)
seed gltf $(find "$data/formats" -name '*.glb' -size -64k)
seed graph_xml ../content/*/graph.xml
seed session ../tests/sessions/*.jsonl
if [ -z "$(ls -A corpus/store 2>/dev/null)" ]; then
  mkdir -p corpus/store
  ../target/debug/kiosk import --quiet "$data/scans/stanford-bunny/bun_zipper_res4.ply" \
    -o corpus/store/bunny.kstore 2>/dev/null || echo "(no store seed: build the kiosk binary first)"
fi
