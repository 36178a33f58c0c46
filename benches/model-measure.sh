#!/usr/bin/env bash
# Measures NEW lavapipe rows for the cost model's validation (issue 25) and runs the model on
# them: `benches/model-measure.sh [OUT_DIR]` (default out/model-measure).
#
# Why new rows: a score on rows the model was looked at against is tainted. The first rows
# (160x120, cubes 64/256/1024, 2026-12-02 09:14-09:35 UTC) were seen while the lane term was
# derived; the second (192x120, cubes 128 and 512, 13:13-13:18 UTC, kept in
# benches/results/model-rows/) were seen while the threads' imbalance and the reflection-point
# start loop were added and the search's timing was split from the reflector textures. The
# third (224x140: subgroup 8 at cubes 64 and 1024, 16 and 4 at 256; 15:10-15:15 UTC, kept in
# benches/results/model-rows-3/) was measured after those changes, and nothing in the model has
# changed since. This fourth set uses settings none of them had: a 256x160 frame; cube sizes 128
# and 512 at subgroup 8, 64 and 1024 at subgroup 16, 64 at subgroup 4; and reflection-point at
# subgroup 4 on every scene there (the third set measured it on teapot only, so its fit had no
# training row at 4 lanes). Its files were copied to benches/results/model-rows-4/<run>.json,
# with the log.
#
# What runs (release binary, `bench --model-rows`: each method in the setting the model replays, the rows
# --model reads; each process writes OUT_DIR/<run>/bench.json):
#   subgroup 8  (LP_NATIVE_VECTOR_WIDTH=256): cube 128 and cube 512, every built-in still scene,
#               methods compute, fragment, ssr, reflection-point, bvh (bvh once, at cube 128);
#   subgroup 16 (512): cubes 64 and 1024, every scene, every method (bvh once, at cube 64);
#   subgroup 4  (128): cube 64, one process per scene: default, sphere-room and teapot, every
#               method; torus and bowl not at all (lavapipe 22.3.6 aborts there,
#               spirv/README.md "Known defect"); under GALLIUM_OVERRIDE_CPU_CAPS=sse4.1 unless
#               it is set (the same defect, see `run`); a process that aborts anyway is rerun
#               one method at a time and an abort is logged, not fatal.
# Each of these runs REPEATS times (default 3) in separate processes, the repeats interleaved
# (every setting once, then again): lavapipe's time varies more from process to process (up to
# 1.7x on the same row in the third set, 2026-12-02) than from frame to frame. --model-from takes a row's median
# over its processes and reports their spread.
# Then: `cubetrace bench --model --model-from <every bench.json>` -o OUT_DIR/model, which fits
# on scene `default` (every cube and subgroup size) and scores every other row.
#
# Timing: 3 frames after 1 warm-up per process (the trace pass median). Run on an IDLE machine
# (no build, no other benchmark): the script refuses when the 1-minute load average is above
# 0.5 unless FORCE=1. Each step prints its wall time; the total is printed at the end (the
# third set's took 289 s on the idle 2-core EPYC, 2026-12-02, the build and the model step not
# counted).
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/model-measure}
# Overrides for a smoke test of the script only (not for the measurement): W, H, SCENES, BIN.
W=${W:-256}
H=${H:-160}
REPEATS=${REPEATS:-3}
BIN=${BIN:-target/release/cubetrace}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
unset CUBETRACE_VALIDATION

if [ "$BIN" = target/release/cubetrace ] && { [ ! -x "$BIN" ] || [ -n "$(find src spirv build.rs Cargo.toml -newer "$BIN" -print -quit)" ]; }; then
    echo "building the release binary (not part of the measurement)..."
    cargo build --release || exit 1
fi
load=$(cut -d' ' -f1 /proc/loadavg)
if [ "${FORCE:-0}" != 1 ] && awk -v l="$load" 'BEGIN { exit !(l > 0.5) }'; then
    echo "load average $load > 0.5: the machine is not idle; wait, or FORCE=1" >&2
    exit 1
fi
mkdir -p "$OUT"
LOG="$OUT/measure.log"
{
    echo "model-measure: $(date -u +%FT%TZ), commit $(git rev-parse --short HEAD), load $load"
    grep -m1 'model name' /proc/cpuinfo
    echo "cpu family $(grep -m1 'cpu family' /proc/cpuinfo | cut -d: -f2), model $(grep -m1 '^model\s' /proc/cpuinfo | cut -d: -f2)"
} | tee "$LOG"
COMMON=(--no-flip --no-heatmaps --no-floor --model-rows --frames 3 --warmup 1 --width "$W" --height "$H")
FILES=()
start_all=$(date +%s)

# run NAME LP_WIDTH CUBE SCENES METHODS: one bench process; returns its exit status.
run() {
    local name=$1 lp=$2 cube=$3 scenes=$4 methods=$5 t0 rc extra=()
    t0=$(date +%s)
    mkdir -p "$OUT/$name"
    # bench refuses an option none of --methods reads: --cube-size is every method's but bvh's
    # (bvh reads no cube map).
    [ "$methods" != bvh ] && extra+=(--cube-size "$cube")
    # Subgroup 4 (128-bit vectors): on AVX2/AVX-512 CPUs lavapipe 22.3.6 corrupts its heap with
    # the current shaders (spirv/README.md "Known defect"; every cube-map, ssr and
    # reflection-point row aborted there from the capture's per-face lists on); with SSE4.1 code
    # it does not, as in the tests. Set GALLIUM_OVERRIDE_CPU_CAPS yourself to choose otherwise.
    local envs=(LP_NATIVE_VECTOR_WIDTH="$lp")
    if [ "$lp" = 128 ] && [ -z "${GALLIUM_OVERRIDE_CPU_CAPS:-}" ]; then
        envs+=(GALLIUM_OVERRIDE_CPU_CAPS=sse4.1)
    fi
    env "${envs[@]}" "$BIN" bench "${COMMON[@]}" "${extra[@]}" \
        --scenes "$scenes" --methods "$methods" -o "$OUT/$name" >"$OUT/$name/stdout.txt" 2>&1
    rc=$?
    if [ $rc -eq 0 ] && [ -f "$OUT/$name/bench.json" ]; then
        FILES+=("$OUT/$name/bench.json")
        echo "$name: ok, $(( $(date +%s) - t0 )) s" | tee -a "$LOG"
    else
        echo "$name: FAILED (exit $rc), $(( $(date +%s) - t0 )) s; see $OUT/$name/stdout.txt" | tee -a "$LOG"
        rc=1
    fi
    return $rc
}

SCENES=${SCENES:-default,sphere-room,teapot,torus,bowl}
for rep in $(seq 1 "$REPEATS"); do
    run "r$rep-sg8-cube128" 256 128 "$SCENES" compute,fragment,ssr,reflection-point,bvh
    run "r$rep-sg8-cube512" 256 512 "$SCENES" compute,fragment,ssr,reflection-point
    run "r$rep-sg16-cube64" 512 64 "$SCENES" compute,fragment,ssr,reflection-point,bvh
    run "r$rep-sg16-cube1024" 512 1024 "$SCENES" compute,fragment,ssr,reflection-point
    for scene in default sphere-room teapot; do
        case ",$SCENES," in *,$scene,*) ;; *) continue ;; esac
        methods=compute,fragment,ssr,reflection-point,bvh
        if ! run "r$rep-sg4-cube64-$scene" 128 64 "$scene" "$methods"; then
            for m in ${methods//,/ }; do
                run "r$rep-sg4-cube64-$scene-$m" 128 64 "$scene" "$m" || true
            done
        fi
    done
done
echo "measured in $(( $(date +%s) - start_all )) s (${#FILES[@]} bench.json files)" | tee -a "$LOG"
[ ${#FILES[@]} -gt 0 ] || exit 1

list=$(IFS=,; echo "${FILES[*]}")
echo "cubetrace bench --model --model-from $list -o $OUT/model" | tee -a "$LOG"
"$BIN" bench --model --model-from "$list" -o "$OUT/model" | tee "$OUT/model.txt"
