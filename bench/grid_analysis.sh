#!/bin/sh
# Grid analysis runs (docs/grid.md): every -grid line of the course with marking, without
# marking (-no_marking) and without the grid; the bunnies at several resolutions and with
# -grid auto; optionally an "AABB-only insertion" build for comparison.
#   sh bench/grid_analysis.sh [BIN]      (default ./raytracer)
# Environment: COURSE (default ../shared/course), RUNS (best of N wall times, default 3),
# BRUTE=0 skips the no-grid column, AABB_BIN=path of a binary built with
#   make BUILD=build-aabb CFLAGS="-O2 -g -DRT_GRID_AABB_ONLY" build-aabb/raytracer
# Prints one line per run: id, variant, CPU and wall seconds, rays, intersections/ray,
# cells/ray (and the -grid auto choice). Needs /usr/bin/time (Debian package time).
BIN=${1:-./raytracer}
COURSE=${COURSE:-../shared/course}
RUNS=${RUNS:-3}
BRUTE=${BRUTE:-1}
case "$BIN" in /*) ;; *) BIN=$(pwd)/$BIN ;; esac
case "$COURSE" in /*) ;; *) COURSE=$(pwd)/$COURSE ;; esac
TMP=$(mktemp -d "${TMPDIR:-/tmp}/gridan.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT INT TERM

# run LABEL VARIANT BIN ARGS... : the run with the least CPU time (user + system, which
# a busy machine inflates less than wall time) of RUNS runs, its wall time, and the
# counters of its -stats block.
run() {
    label=$1 variant=$2 bin=$3; shift 3
    best="" bestwall=""
    i=0
    while [ $i -lt "$RUNS" ]; do
        (cd "$COURSE" && /usr/bin/time -f "%e %U %S" -o "$TMP/time.txt" "$bin" "$@" -stats \
            > "$TMP/stats.txt" 2>/dev/null) || { echo "$label $variant FAILED"; return; }
        read -r wall user sys < "$TMP/time.txt"
        cpu=$(echo "$user + $sys" | bc)
        if [ -z "$best" ] || [ "$(echo "$cpu < $best" | bc)" = 1 ]; then
            best=$cpu bestwall=$wall
            cp "$TMP/stats.txt" "$TMP/best.txt"
        fi
        i=$((i + 1))
    done
    awk -v id="$label" -v var="$variant" -v t="$best" -v w="$bestwall" '
        /num non-shadow rays/ {ns = $NF} /num shadow rays/ {sh = $NF}
        /total intersections/ {it = $NF} /total cells traversed/ {ce = $NF}
        /grid auto:/ {auto = $3 "x" $5 "x" $7}
        END { r = ns + sh; if (r == 0) r = 1;
              printf "%-5s %-24s cpu %7.2fs wall %7.2fs %8d rays %9.2f int/ray %6.2f cells/ray %s\n",
                     id, var, t, w, ns + sh, it / r, ce / r, auto }' "$TMP/best.txt"
}

# Course lines with -grid, without -visualize_grid.
grep -- '-grid' "$COURSE/commands.txt" | grep -v visualize_grid | while IFS='|' read -r id args; do
    # shellcheck disable=SC2086
    set -- $(echo "$args" | sed "s#-output [^ ]*#-output $TMP/o.tga#; s# -stats##")
    run "$id" "grid+marking" "$BIN" "$@"
    run "$id" "grid-no-marking" "$BIN" "$@" -no_marking
    if [ -n "$AABB_BIN" ]; then run "$id" "grid-aabb-insertion" "$AABB_BIN" "$@"; fi
    auto=$(echo "$args" | sed "s#-output [^ ]*#-output $TMP/o.tga#; s# -stats##; s#-grid [0-9]* [0-9]* [0-9]*#-grid auto#")
    # shellcheck disable=SC2086
    run "$id" "grid-auto" "$BIN" $auto
    if [ "$BRUTE" != 0 ]; then
        nog=$(echo "$args" | sed "s#-output [^ ]*#-output $TMP/o.tga#; s# -stats##; s#-grid [0-9]* [0-9]* [0-9]*##")
        # shellcheck disable=SC2086
        RUNS=1 run "$id" "no-grid" "$BIN" $nog
    fi
done

# Resolution sweeps on the bunnies (with shadows, like the course lines).
for scene in scene6_05_bunny_mesh_1k.txt scene6_07_bunny_mesh_40k.txt; do
    for n in "5 5 4" "10 10 8" "20 20 16" "40 40 33" "80 80 66" "160 160 132"; do
        # shellcheck disable=SC2086
        run "${scene#scene6_}" "grid $n" "$BIN" -input $scene -size 200 200 -shadows -grid $n
    done
done
# Shadows and bounces: scene 11 (mirror floor) with and without them.
for extra in "" "-shadows" "-shadows -bounces 1 -weight 0.01" "-shadows -bounces 5 -weight 0.01"; do
    # shellcheck disable=SC2086
    run "11" "grid $extra" "$BIN" -input scene6_11_mirrored_floor.txt -size 200 200 -grid 40 10 40 $extra
done
