#!/bin/sh
# Builds the harness: grbl/planner.c (verbatim) + the two functions of grbl/nuts_bolts.c
# it calls (cut out of the verbatim copy at build time) + harness.c.
# -fsingle-precision-constant: constants are float, as on the ATmega328p (double = float).
# Usage: build.sh [OUT_DIR] [BLOCK_BUFFER_SIZE]  (planner.h's default: 16, 15 blocks usable)
set -eu
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-$here/build}
mkdir -p "$out"
{
  echo '#include "grbl.h"'
  sed -n '/^float convert_delta_vector_to_unit_vector/,$p' "$here/grbl/nuts_bolts.c"
} > "$out/nuts_bolts_vectors.c"
size=${2:-16}
${CC:-cc} -O2 -DBLOCK_BUFFER_SIZE="$size" -std=gnu99 -fsingle-precision-constant -Wall -Wno-unused-variable \
  -I"$here" -o "$out/grbl_harness" \
  "$here/harness.c" "$here/grbl/planner.c" "$out/nuts_bolts_vectors.c" -lm
echo "$out/grbl_harness"
