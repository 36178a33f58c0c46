#!/usr/bin/env bash
# Renders every built-in scene with every method, and with the options that change which passes
# run, to EXR files in OUT, with the cubetrace binary BIN. Two such folders (one per commit) are
# then compared channel by channel by `tests/records.rs` (`records_are_unchanged`, ignored: the
# committed hashes of `records_match_the_committed_hashes`, which CI checks at 32x24, at 160x120
# with more variants):
#
#   tests/records/render.sh OLD_CHECKOUT/target/release/cubetrace /tmp/records-old
#   tests/records/render.sh target/release/cubetrace /tmp/records-new
#   CUBETRACE_RECORDS="/tmp/records-old /tmp/records-new" \
#     cargo test --release --test records -- --ignored
#
# A refactor must leave every file equal (the ID channels aside where the numbering changed on
# purpose: CUBETRACE_RECORDS_SKIP="object_id primitive_id").
set -euo pipefail
bin=${1:?usage: render.sh BIN OUT}
out=${2:?usage: render.sh BIN OUT}
size=(--width 160 --height 120)
mkdir -p "$out"
scenes=$("$bin" scenes | awk '{print $1}')
variants=(
  "compute" "--method compute"
  "fragment" "--method fragment"
  "envmap" "--method envmap"
  "ssr" "--method ssr"
  "reflection-point" "--method reflection-point"
  "bvh" "--method bvh"
  "reference" "--method reference"
  "fragment-threshold" "--method fragment --criterion threshold"
  "fragment-sign-step" "--method fragment --criterion sign-change --sampling constant-step --steps 64"
  "compute-centre" "--method compute --criterion centre"
  "fragment-centre" "--method fragment --criterion centre"
  "compute-spp4-gaussian" "--method compute --spp 4 --filter gaussian"
  "bvh-spp4" "--method bvh --spp 4"
  "reference-spp4-gaussian" "--method reference --spp 4 --filter gaussian"
  "fragment-walk" "--method fragment --criterion centre --no-accel"
  "fragment-strict" "--method fragment --criterion centre --strict"
  "fragment-envmap-fallback" "--method fragment --fallback envmap"
  "compute-flag-fallback" "--method compute --fallback flag --no-reflector-check"
  "compute-bounces3" "--method compute --bounces 3"
  "fragment-bounces0" "--method fragment --bounces 0"
  "bvh-bounces2" "--method bvh --bounces 2"
  "compute-cmos3" "--method compute --cmos 3 --cube-size 64"
  "ssr-background" "--method ssr --fallback background"
)
for scene in $scenes; do
  for ((k = 0; k < ${#variants[@]}; k += 2)); do
    name=${variants[k]}
    # A render the command refuses writes no file and is not compared; it is named here.
    # shellcheck disable=SC2086
    if ! "$bin" render "$scene" "${size[@]}" ${variants[k + 1]} -o "$out/$scene-$name.exr" \
      >/dev/null 2>"$out/$scene-$name.err"; then
      echo "$scene $name: refused: $(tail -n 1 "$out/$scene-$name.err")"
    fi
    rm -f "$out/$scene-$name.err"
  done
  echo "$scene: $(( ${#variants[@]} / 2 )) renders"
done
