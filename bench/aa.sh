#!/bin/bash
# Antialiasing benchmark (make bench, section (f); docs/benchmarks.md): course lines 07 and
# 17a at 400x400 on one thread, one sample per pixel against 16 (uniform with the box,
# jittered with the Gaussian 0.4 of the course's lines, and jittered with the box 0.5,
# which has no neighbours to weigh: the Gaussian's whole cost is the difference). Figures
# are the render phase's CPU time from -timings (the calling thread, which does all the
# work with -threads 1: the machine may be shared); the settings are interleaved round by
# round, in an order that turns each round, so a burst of load hits them alike.
# trace/filter: the film's two phases; the separable weights of a random sample are
# computed as it is queued, so they count in trace, and the gauss-box column is the
# filter's full cost (weights, wider stride, filtering, the margin of traced pixels).
# Usage: bash bench/aa.sh RAYTRACER COURSE_DIR [RUNS]
set -u
export LC_ALL=C
BIN=$1 COURSE=$2 RUNS=${3:-3}
TMP=$(mktemp -d "${TMPDIR:-/tmp}/rt_aa.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT
median() { printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
field() { sed -n "s/.*$1 \([0-9.]*\) ms.*/\1/p" "$TMP/err" | tail -n 1; }
SETS=("" "-uniform_samples 16" "-jittered_samples 16 -gaussian_filter 0.4" "-jittered_samples 16 -box_filter 0.5")
echo "== (f) antialiasing: 16 samples per pixel against 1, course lines at 400x400, -threads 1"
echo "   render-phase CPU ms (-timings), median of $RUNS interleaved rounds; trace/filter: the"
echo "   film's phases; filt%: filtering / render; gauss-box: the Gaussian's whole cost, % of"
echo "   its render. Target: 16 samples <= 12x one sample, filtering < 10%."
printf '   %-5s %-42s %9s %7s %9s %9s %6s %9s\n' line samples render "x 1spp" trace filter filt% gauss-box
for line in 07 17a; do
    case $line in
    07) A=(-input "$COURSE/scene6_07_bunny_mesh_40k.txt" -grid 40 40 33 -shadows) ;;
    17a) A=(-input "$COURSE/scene6_17_marble_vase.txt" -grid 15 30 15 -bounces 1 -shadows) ;;
    esac
    [ -f "${A[1]}" ] || { echo "   $line: scene not found, skipped"; continue; }
    declare -A R=() T=() F=()
    for ((k = 0; k < RUNS; k++)); do
        # Round k starts at setting k mod 4: each setting takes each place in the round
        # as often (a run is ~1 ms faster in one place than another; same binary and
        # setting twice in a row on this host, 15 rounds, 2026-11-29 lead34).
        for j in "${!SETS[@]}"; do
            i=$(( (j + k) % ${#SETS[@]} ))
            # shellcheck disable=SC2086
            "$BIN" "${A[@]}" -size 400 400 -output "$TMP/o.tga" -threads 1 -timings ${SETS[$i]} \
                >/dev/null 2>"$TMP/err"
            R[$i]+="$(field 'render phase') " T[$i]+="$(field 'tracing') " F[$i]+="$(field 'filtering') "
        done
    done
    # shellcheck disable=SC2086
    base=$(median ${R[0]})
    # shellcheck disable=SC2086
    box=$(median ${R[3]})
    for i in "${!SETS[@]}"; do
        # shellcheck disable=SC2086
        rm=$(median ${R[$i]})
        ratio=$(awk -v a="$rm" -v b="$base" 'BEGIN { printf "%.2f", a / b }')
        t=- f=- pct=- gb=-
        if [ "$i" -gt 0 ]; then
            # shellcheck disable=SC2086
            t=$(median ${T[$i]}) f=$(median ${F[$i]})
            pct=$(awk -v r="$rm" -v f="$f" 'BEGIN { printf "%.1f", 100 * f / r }')
        fi
        [ "$i" = 2 ] && gb=$(awk -v g="$rm" -v b="$box" 'BEGIN { printf "%.0f (%.1f%%)", g - b, 100 * (g - b) / g }')
        printf '   %-5s %-42s %9s %7s %9s %9s %6s %9s\n' "$line" "${SETS[$i]:-(1 centred sample)}" "$rm" "$ratio" "$t" "$f" "$pct" "$gb"
    done
    unset R T F
done
echo ""
