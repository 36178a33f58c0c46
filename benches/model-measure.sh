#!/usr/bin/env bash
# Measures NEW lavapipe rows for the cost model's validation (issue 25) and runs the model on
# them: `benches/model-measure.sh [OUT_DIR]` (default out/model-measure).
#
# Why new rows: a score on rows the model was looked at against is tainted. The first rows
# (160x120, cubes 64/256/1024, 2026-12-02 09:14-09:35 UTC) were seen while the lane term was
# derived; the second (192x120, cubes 128 and 512, 13:13-13:18 UTC, kept in
# benches/results/model-rows/) were seen while the threads' imbalance and the reflection-point
# start loop were added and the search's timing was split from the reflector textures. These
# rows use settings the model was never compared with: a 224x140 frame; cube sizes 64 and 1024
# at subgroup 8, 256 at subgroups 16 and 4. Their files were copied to
# benches/results/model-rows-3/<run>.json, with the log.
#
# What runs (release binary, `bench --defaults-only`: each method's default setting, the rows
# --model reads; each process writes OUT_DIR/<run>/bench.json):
#   subgroup 8  (LP_NATIVE_VECTOR_WIDTH=256): cube 64 and cube 1024, every built-in still scene,
#               methods compute, fragment, ssr, reflection-point, bvh (bvh once, at cube 64);
#   subgroup 16 (512): cube 256, every scene, every method;
#   subgroup 4  (128): cube 256, one process per scene: default and sphere-room without
#               reflection-point, teapot with it; torus and bowl not at all (lavapipe 22.3.6
#               aborts there, spirv/README.md "Known defect"); a process that aborts anyway is
#               rerun one method at a time and an abort is logged, not fatal.
# Each of these runs REPEATS times (default 3) in separate processes, the repeats interleaved
# (every setting once, then again): lavapipe's time varies more from process to process (up to
# 1.7x on the same row in the third set, 2026-12-02) than from frame to frame. --model-from takes a row's median
# over its processes and reports their spread.
# Then: `cubetrace bench --model --model-from <every bench.json>` -o OUT_DIR/model, which fits
# on scene `default` (every cube and subgroup size) and scores every other row.
#
# Timing: 3 frames after 1 warm-up per process (the trace pass median). Run on an IDLE machine
# (no build, no other benchmark): the script refuses when the 1-minute load average is above
# 0.5 unless FORCE=1. Each step prints its wall time; the total is printed at the end (289 s on
# the idle 2-core EPYC, 2026-12-02, the build and the model step not counted).
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/model-measure}
# Overrides for a smoke test of the script only (not for the measurement): W, H, SCENES, BIN.
W=${W:-224}
H=${H:-140}
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
COMMON=(--no-flip --no-heatmaps --no-floor --defaults-only --frames 3 --warmup 1 --width "$W" --height "$H")
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
    LP_NATIVE_VECTOR_WIDTH=$lp "$BIN" bench "${COMMON[@]}" "${extra[@]}" \
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
    run "r$rep-sg8-cube64" 256 64 "$SCENES" compute,fragment,ssr,reflection-point,bvh
    run "r$rep-sg8-cube1024" 256 1024 "$SCENES" compute,fragment,ssr,reflection-point
    run "r$rep-sg16-cube256" 512 256 "$SCENES" compute,fragment,ssr,reflection-point,bvh
    for scene in default sphere-room teapot; do
        case ",$SCENES," in *,$scene,*) ;; *) continue ;; esac
        methods=compute,fragment,ssr,bvh
        [ "$scene" = teapot ] && methods=$methods,reflection-point
        if ! run "r$rep-sg4-cube256-$scene" 128 256 "$scene" "$methods"; then
            for m in ${methods//,/ }; do
                run "r$rep-sg4-cube256-$scene-$m" 128 256 "$scene" "$m" || true
            done
        fi
    done
done
echo "measured in $(( $(date +%s) - start_all )) s (${#FILES[@]} bench.json files)" | tee -a "$LOG"
[ ${#FILES[@]} -gt 0 ] || exit 1

list=$(IFS=,; echo "${FILES[*]}")
echo "cubetrace bench --model --model-from $list -o $OUT/model" | tee -a "$LOG"
"$BIN" bench --model --model-from "$list" -o "$OUT/model" | tee "$OUT/model.txt"
