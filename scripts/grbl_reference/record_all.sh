#!/bin/sh
# Regenerates crates/schedule/tests/data/grbl_reference/*.txt.gz: for each program of
# programs.txt, dexcut's blocks (examples/grbl_blocks.rs) planned by the real grbl planner
# (harness.c + grbl/planner.c, build.sh) with its settings dump. Needs cargo and a C compiler.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
data=$root/crates/schedule/tests/data/grbl_reference
(cd "$root" && cargo build --quiet --release -p schedule --example grbl_blocks)
blocks=${CARGO_TARGET_DIR:-$root/target}/release/examples/grbl_blocks
grep -v '^#' "$here/programs.txt" | while read -r name program size dump; do
  [ -n "$name" ] || continue
  size=${size:-16}
  dump=${dump:-settings.txt}
  harness=$("$here/build.sh" "$here/build/bbs$size" "$size" | tail -1)
  (cd "$root" && "$blocks" "$program" "scripts/grbl_reference/$dump") > "$here/build/$name.blocks.txt"
  {
    echo "# $name: $program BLOCK_BUFFER_SIZE $size $dump"
    "$harness" "$here/$dump" < "$here/build/$name.blocks.txt"
  } | gzip -9n > "$data/$name.txt.gz"
  echo "$name: $(wc -l < "$here/build/$name.blocks.txt") blocks, $(zcat "$data/$name.txt.gz" | tail -1)"
done
