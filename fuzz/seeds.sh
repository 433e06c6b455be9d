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
seed las "$data"/formats/*.las "$data"/formats/*.laz
seed e57 "$data"/formats/*.e57
if [ -z "$(ls -A corpus/kiosk_toml 2>/dev/null)" ]; then
  # The README's example (every key), and the window layouts the tests use.
  mkdir -p corpus/kiosk_toml
  sed -n '/^```toml$/,/^```$/{/^```/d;p}' ../README.md >corpus/kiosk_toml/readme.toml
  printf '[projection]\nmonitor = 1\nrotation = 90\n[controller]\nmonitor = 0\n' >corpus/kiosk_toml/rotated.toml
  printf 'languages = ["it", "en"]\nattract_after_secs = 5\nreset_after_secs = 9\n' >corpus/kiosk_toml/timeouts.toml
  : >corpus/kiosk_toml/empty.toml
fi
if [ -z "$(ls -A corpus/store 2>/dev/null)" ]; then
  mkdir -p corpus/store
  ../target/debug/kiosk import --quiet "$data/scans/stanford-bunny/bun_zipper_res4.ply" \
    -o corpus/store/bunny.kstore 2>/dev/null || echo "(no store seed: build the kiosk binary first)"
fi
