#!/bin/bash
# Antialiasing benchmark (make bench, section (f); docs/benchmarks.md): course lines 07 and
# 17a at 400x400 on one thread, one sample per pixel against 16 (uniform with the box,
# jittered with the Gaussian 0.4 of the course's lines). Figures are CPU times (the machine
# may be shared): the render is the whole process's CPU minus that of the same command at
# -size 1 1 (parse, grid, start-up); tracing and filtering come from -timings (CPU time of
# the calling thread, which does all the work with -threads 1).
# Usage: bash bench/aa.sh RAYTRACER COURSE_DIR [RUNS]
set -u
export LC_ALL=C
BIN=$1 COURSE=$2 RUNS=${3:-3}
TMP=$(mktemp -d "${TMPDIR:-/tmp}/rt_aa.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT
median() { printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
cpu_ms() { # runs the command, prints user+sys ms; leaves stderr in $TMP/err
    local TIMEFORMAT='%U %S' t
    t=$( { time "$@" >/dev/null 2>"$TMP/err"; } 2>&1 | tail -n 1)
    echo "$t" | awk '{ printf "%.1f", ($1 + $2) * 1000 }'
}
echo "== (f) antialiasing: 16 samples per pixel against 1, course lines at 400x400, -threads 1"
echo "   CPU ms, median of $RUNS; render = process CPU minus the same command at -size 1 1;"
echo "   trace/filter: the film's phases (-timings). Target: 16 samples <= 12x one sample,"
echo "   filtering < 10% of the render."
printf '   %-5s %-42s %9s %9s %8s %9s %9s %7s\n' line samples render "x 1spp" "" trace filter "filt%"
for line in 07 17a; do
    case $line in
    07) A=(-input "$COURSE/scene6_07_bunny_mesh_40k.txt" -grid 40 40 33 -shadows) ;;
    17a) A=(-input "$COURSE/scene6_17_marble_vase.txt" -grid 15 30 15 -bounces 1 -shadows) ;;
    esac
    [ -f "${A[1]}" ] || { echo "   $line: scene not found, skipped"; continue; }
    base=
    for S in "" "-uniform_samples 16" "-jittered_samples 16 -gaussian_filter 0.4"; do
        r=() tr=() fi=()
        for ((k = 0; k < RUNS; k++)); do
            # shellcheck disable=SC2086
            full=$(cpu_ms "$BIN" "${A[@]}" -size 400 400 -output "$TMP/o.tga" -threads 1 -timings $S)
            tr+=("$(sed -n 's/.*film: tracing \([0-9.]*\) ms.*/\1/p' "$TMP/err")")
            fi+=("$(sed -n 's/.*filtering \([0-9.]*\) ms.*/\1/p' "$TMP/err")")
            # shellcheck disable=SC2086
            one=$(cpu_ms "$BIN" "${A[@]}" -size 1 1 -output "$TMP/o.tga" -threads 1 $S)
            r+=("$(awk -v a="$full" -v b="$one" 'BEGIN { printf "%.1f", a - b }')")
        done
        rm=$(median "${r[@]}")
        [ -z "$S" ] && base=$rm
        ratio=$(awk -v a="$rm" -v b="$base" 'BEGIN { printf "%.2f", a / b }')
        if [ -n "$S" ]; then
            t=$(median "${tr[@]}") f=$(median "${fi[@]}")
            pct=$(awk -v t="$t" -v f="$f" 'BEGIN { printf "%.1f", 100 * f / (t + f) }')
        else
            t=- f=- pct=-
        fi
        printf '   %-5s %-42s %9s %9s %8s %9s %9s %7s\n' "$line" "${S:-(1 centred sample)}" "$rm" "$ratio" "" "$t" "$f" "$pct"
    done
done
echo ""
