#!/bin/bash
# Split-render benchmark (make bench, section (h); docs/distributed.md): course line 07
# (the 40k bunny, -grid 40 40 33 -shadows) at 1920x1080, one sample per pixel and 16
# (uniform with the box filter, which needs no margin; jittered with the Gaussian 0.4,
# whose support reaches one pixel into the neighbouring tiles).
#  - Tile overhead: the CPU time (user+sys of every process) of 64 `-tile k 64` renders
#    plus the merge, against one whole render, each process on one thread. What the
#    tiles add is every process's start-up, parse and grid build, plus the rows of the
#    filter's margin that neighbouring tiles both trace. Measured without and with the
#    set-up cache (-cache), which leaves mostly start-up and the margin.
#  - MPI: wall time of `mpirun --oversubscribe $MPIRUN_FLAGS -np N raytracer-mpi ...
#    -threads 1` for N = 1, 2 and 4 (4 is oversubscribed on two cores), interleaved run
#    by run, median of RUNS; speed-up against N = 1; and the CPU time (user+sys) of the
#    whole job (mpirun and its ranks), median of RUNS, which the machine's other load
#    does not inflate the way it does the wall time. In the same rounds, the host's own
#    ceiling: two plain renders at once against one (2 T1 / T2; 2.00 on two free
#    cores), so -np 2's figure can be read against what the machine gave. A last row
#    renders course line 11b at the same size (N = 1 and 2). MPIRUN_FLAGS defaults to the
#    one-machine transports (--mca pml ob1 --mca btl self,vader: shared memory only,
#    no probing for network hardware; docs/distributed.md); set it empty for OpenMPI's
#    own choice; MPIRUN_ENV (default PMIX_MCA_gds=hash) is mpirun's environment. Skipped
#    when raytracer-mpi or mpirun is missing.
# Every part's merge is compared with the whole render (cmp): a difference is reported.
# On a machine shared with others, Linux shares CPU between login sessions
# (/proc/sys/kernel/sched_autogroup_enabled): while other sessions are busy, -np 2 gets
# about what one process gets, whatever nice says (docs/distributed.md, measured points):
# run this script in a session of its own (setsid bash bench/dist.sh ...).
# DIST_PARTS: "tiles mpi" (default), or one of them.
# Usage: bash bench/dist.sh RAYTRACER RAYTRACER_MPI COURSE_DIR [RUNS]
set -u
export LC_ALL=C
BIN=$1 MPI_BIN=$2 COURSE=$3 RUNS=${4:-3}
TMP=$(mktemp -d "${TMPDIR:-/tmp}/rt_dist.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT
median() { printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
# cpu_ms CMD...: runs it, prints user+sys ms of it and its children.
cpu_ms() {
    local TIMEFORMAT='%U %S' t
    t=$( { time "$@" >/dev/null 2>"$TMP/err"; } 2>&1 | tail -n 1)
    echo "$t" | awk '{ printf "%.1f", ($1 + $2) * 1000 }'
}
# wall_cpu_ms CMD...: runs it, prints its wall ms and the user+sys ms of it and its
# children.
wall_cpu_ms() {
    local TIMEFORMAT='%R %U %S' t
    t=$( { time "$@" >/dev/null 2>"$TMP/err"; } 2>&1 | tail -n 1)
    echo "$t" | awk '{ printf "%.1f %.1f", $1 * 1000, ($2 + $3) * 1000 }'
}
DIST_PARTS=${DIST_PARTS:-tiles mpi}
MPIRUN_FLAGS=${MPIRUN_FLAGS-"--mca pml ob1 --mca btl self,vader"}
# Environment for mpirun (assignments, as for env): PMIx's hash store instead of its
# shared-memory one (mpirun then sets up no shared-memory segments and locks for the
# job's data; measured in bench/REPORT.txt, dist's section); empty for none.
MPIRUN_ENV=${MPIRUN_ENV-"PMIX_MCA_gds=hash"}
SCENE=$COURSE/scene6_07_bunny_mesh_40k.txt
A=(-input "$SCENE" -grid 40 40 33 -shadows -size 1920 1080 -threads 1)
N_TILES=64
# OpenMPI refuses to run as root unless told it may (as in CI).
[ "$(id -u)" = 0 ] && export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
echo "== (h) split renders: course line 07 at 1920x1080, one thread per process"
echo "   tile overhead: CPU ms (user+sys) of $N_TILES '-tile k $N_TILES' processes + merge vs one"
echo "   whole render; target: within 10%. MPI: wall ms, median of $RUNS, interleaved;"
echo "   target: -np 2 >= 1.8x -np 1."
if [ ! -f "$SCENE" ]; then
    echo "   scene not found, skipped"
    exit 0
fi
pct() { awk -v w="$1" -v t="$2" -v m="$3" 'BEGIN { printf "%+.1f%%", 100 * (t + m - w) / w }'; }
add() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", a + b }'; }
# The set-up cache (-cache) makes the parts after the first map the parsed mesh and the
# grid instead of building them. Both ways are measured part by part, paired (part k
# without, then with the cache, so the machine's drift hits both alike), in TILE_RUNS
# rounds (default 1; medians); the whole render runs before and after the parts of each
# round (their mean).
case " $DIST_PARTS " in *" tiles "*) ;; *) SKIP_TILES=1 ;; esac
if [ -z "${SKIP_TILES:-}" ]; then
    TILE_RUNS=${TILE_RUNS:-1}
    echo "   tiles: $N_TILES processes without -cache; +cache: with -cache (a fresh file: the first"
    echo "   part builds it), part k of both run back to back; medians of $TILE_RUNS round(s)"
    printf '   %-42s %8s %8s %8s %6s %9s %9s\n' samples whole tiles +cache merge overhead +cache
    for S in "" "-uniform_samples 16" "-jittered_samples 16 -gaussian_filter 0.4"; do
        ws=() ts=() cs=() ms=()
        for ((r = 0; r < TILE_RUNS; r++)); do
            rm -f "$TMP/setup.cache"
            # shellcheck disable=SC2086
            w0=$(cpu_ms "$BIN" "${A[@]}" $S -output "$TMP/whole.tga")
            t=0 c=0
            for ((k = 0; k < N_TILES; k++)); do
                # shellcheck disable=SC2086
                t=$(add "$t" "$(cpu_ms "$BIN" "${A[@]}" $S -tile $k $N_TILES -output "$TMP/part$k.tga")")
                # shellcheck disable=SC2086
                c=$(add "$c" "$(cpu_ms "$BIN" "${A[@]}" $S -cache "$TMP/setup.cache" -tile $k $N_TILES \
                    -output "$TMP/cpart$k.tga")")
            done
            # shellcheck disable=SC2086
            w1=$(cpu_ms "$BIN" "${A[@]}" $S -output "$TMP/whole.tga")
            ws+=("$(awk -v a="$w0" -v b="$w1" 'BEGIN { printf "%.1f", (a + b) / 2 }')")
            ts+=("$t") cs+=("$c")
            ms+=("$(cpu_ms "$BIN" -merge "$TMP/merged.tga" "$TMP"/part*.tga)")
            cmp -s "$TMP/merged.tga" "$TMP/whole.tga" || echo "   !! merged tiles differ from the whole render"
            "$BIN" -merge "$TMP/merged.tga" "$TMP"/cpart*.tga
            cmp -s "$TMP/merged.tga" "$TMP/whole.tga" || echo "   !! merged tiles (-cache) differ from the whole render"
            rm -f "$TMP"/part*.tga "$TMP"/cpart*.tga "$TMP/setup.cache"
        done
        whole=$(median "${ws[@]}") tiles=$(median "${ts[@]}") cached=$(median "${cs[@]}")
        merge=$(median "${ms[@]}")
        printf '   %-42s %8s %8s %8s %6s %9s %9s\n' "${S:-(1 centred sample)}" "$whole" "$tiles" \
            "$cached" "$merge" "$(pct "$whole" "$tiles" "$merge")" "$(pct "$whole" "$cached" "$merge")"
    done
fi
# Tile shapes (opt-in: DIST_PARTS containing "shapes"; a 4K round takes minutes): 64
# parts as bands (-tile k 64) against an 8x8 grid of square-ish tiles (-tile k 8x8), both
# with -cache, of BIN and of STATIC_BIN (default: raytracer-static beside BIN, when
# built), at each of SHAPE_SIZES (default "1920x1080 3840x2160": the issue's motivating
# 4K antialiased frame), 16 uniform samples (box filter: no margin) and 16 jittered with
# the Gaussian 0.4 (its margin is traced again by every tile that borders another: a
# band borders two along its width, a square along its perimeter). Band k and square k
# run back to back, so drift hits both alike; the whole render runs before and after
# (their mean). CPU = user+sys of every process. Run the whole script in a session of
# its own (setsid bash bench/dist.sh ...: the kernel shares CPU per session), not each
# part: `setsid -w` per part would add its own process (~8 ms of CPU here) to every
# part's figure.
case " $DIST_PARTS " in *" shapes "*)
    STATIC_BIN=${STATIC_BIN:-$(dirname "$BIN")/raytracer-static}
    SHAPE_BINS=("$BIN")
    [ -x "$STATIC_BIN" ] && SHAPE_BINS+=("$STATIC_BIN")
    echo "   tile shapes: CPU ms of 64 bands (-tile k 64) and of an 8x8 grid (-tile k 8x8), both"
    echo "   with -cache, + merge, vs one whole render; load at the start: $(cut -d' ' -f1-3 /proc/loadavg)"
    printf '   %-10s %-8s %-30s %9s %9s %9s %6s %9s %9s\n' size binary samples whole bands squares \
        merge "bands" "squares"
    for SZ in ${SHAPE_SIZES:-1920x1080 3840x2160}; do
        SA=(-input "$SCENE" -grid 40 40 33 -shadows -size "${SZ%x*}" "${SZ#*x}" -threads 1)
        for S in "-uniform_samples 16" "-jittered_samples 16 -gaussian_filter 0.4"; do
            for B in "${SHAPE_BINS[@]}"; do
                rm -f "$TMP/b.cache" "$TMP/s.cache"
                # shellcheck disable=SC2086
                w0=$(cpu_ms "$B" "${SA[@]}" $S -output "$TMP/whole.tga")
                t=0 q=0
                for ((k = 0; k < 64; k++)); do
                    # shellcheck disable=SC2086
                    t=$(add "$t" "$(cpu_ms "$B" "${SA[@]}" $S -cache "$TMP/b.cache" \
                        -tile $k 64 -output "$TMP/band$k.tga")")
                    # shellcheck disable=SC2086
                    q=$(add "$q" "$(cpu_ms "$B" "${SA[@]}" $S -cache "$TMP/s.cache" \
                        -tile $k 8x8 -output "$TMP/square$k.tga")")
                done
                # shellcheck disable=SC2086
                w1=$(cpu_ms "$B" "${SA[@]}" $S -output "$TMP/whole.tga")
                whole=$(awk -v a="$w0" -v b="$w1" 'BEGIN { printf "%.1f", (a + b) / 2 }')
                m=$(cpu_ms "$B" -merge "$TMP/merged.tga" "$TMP"/band*.tga)
                cmp -s "$TMP/merged.tga" "$TMP/whole.tga" || echo "   !! merged bands differ from the whole render"
                "$B" -merge "$TMP/merged.tga" "$TMP"/square*.tga
                cmp -s "$TMP/merged.tga" "$TMP/whole.tga" || echo "   !! merged squares differ from the whole render"
                rm -f "$TMP"/band*.tga "$TMP"/square*.tga
                printf '   %-10s %-8s %-30s %9s %9s %9s %6s %9s %9s\n' "$SZ" \
                    "$(case "$B" in *static) echo static ;; *) echo dynamic ;; esac)" \
                    "${S/-gaussian_filter/+ Gaussian}" "$whole" "$t" "$q" "$m" "$(pct "$whole" "$t" "$m")" \
                    "$(pct "$whole" "$q" "$m")"
            done
        done
    done
    echo "   (whole: mean of the render before and after the parts; w0 w1 spread shows the drift)"
    echo "   load at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
    ;;
esac
case " $DIST_PARTS " in *" mpi "*) ;; *) echo ""; exit 0 ;; esac
if [ ! -x "$MPI_BIN" ] || ! command -v mpirun >/dev/null 2>&1; then
    echo "   MPI: raytracer-mpi or mpirun missing (make mpi), skipped"
    echo ""
    exit 0
fi
echo "   MPI: ${MPIRUN_ENV:+$MPIRUN_ENV }mpirun --oversubscribe ${MPIRUN_FLAGS:-(no flags)}; load at the start: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "   host: two plain renders (BIN, -threads 1) at once vs one alone, in the same rounds:"
echo "   2*T(one)/T(two), the most -np 2 can reach on this machine's render (1.00-2.00)"
printf '   %-44s %9s %9s %9s %7s %7s %6s   %s\n' "line, samples" "np 1" "np 2" "np 4" "x np2" \
    "x np4" "host" "CPU ms np 1 / 2 / 4"
# mpi_row LABEL NP4 ARGS...: RUNS interleaved rounds of -np 1, 2 (and 4 when NP4 = 1)
# and the two plain renders, medians.
mpi_row() {
    local label=$1 np4=$2 k np t c nps=(1 2)
    shift 2
    [ "$np4" = 1 ] && nps+=(4)
    w1=() w2=() w4=() c1=() c2=() c4=() h=()
    for ((k = 0; k < RUNS; k++)); do
        for np in "${nps[@]}"; do
            # shellcheck disable=SC2086
            read -r t c < <(wall_cpu_ms env $MPIRUN_ENV mpirun --oversubscribe $MPIRUN_FLAGS -np $np "$MPI_BIN" \
                "$@" -output "$TMP/m$np.tga")
            eval "w$np+=(\"$t\") c$np+=(\"$c\")"
        done
        read -r t1 c < <(wall_cpu_ms "$BIN" "$@" -output "$TMP/p1.tga")
        # shellcheck disable=SC2016
        read -r t2 c < <(wall_cpu_ms bash -c '"$@" -output "$0/p2.tga" & "$@" -output "$0/p3.tga"; wait' \
            "$TMP" "$BIN" "$@")
        h+=("$(awk -v a="$t1" -v b="$t2" 'BEGIN { printf "%.3f", 2 * a / b }')")
        cmp -s "$TMP/m1.tga" "$TMP/p1.tga" && cmp -s "$TMP/m2.tga" "$TMP/p1.tga" &&
            { [ "$np4" != 1 ] || cmp -s "$TMP/m4.tga" "$TMP/p1.tga"; } ||
            echo "   !! raytracer-mpi images differ from raytracer's"
    done
    m1=$(median "${w1[@]}") m2=$(median "${w2[@]}")
    m4=-; x4=-; cm4=-
    if [ "$np4" = 1 ]; then
        m4=$(median "${w4[@]}") cm4=$(median "${c4[@]}")
        x4=$(awk -v a="$m1" -v b="$m4" 'BEGIN { printf "%.2f", a / b }')
    fi
    printf '   %-44s %9s %9s %9s %7s %7s %6s   %s / %s / %s\n' "$label" "$m1" "$m2" "$m4" \
        "$(awk -v a="$m1" -v b="$m2" 'BEGIN { printf "%.2f", a / b }')" "$x4" \
        "$(median "${h[@]}")" "$(median "${c1[@]}")" "$(median "${c2[@]}")" "$cm4"
}
for S in "" "-uniform_samples 16" "-jittered_samples 16 -gaussian_filter 0.4"; do
    # shellcheck disable=SC2086
    mpi_row "07 ${S:-(1 centred sample)}" 1 "${A[@]}" $S
done
# A heavier frame of the same size (course line 11b, the mirrored floor with shadows
# and one bounce, 16 uniform samples: ~12 s of CPU against line 07's ~3; line 17a,
# first chosen, fell to ~3 s with the packet shading of its materials), where
# OpenMPI's fixed ~0.3 s per job weighs less; -np 1 and 2 only. Beside line 07, not
# instead of it.
SCENE11=$COURSE/scene6_11_mirrored_floor.txt
if [ -f "$SCENE11" ]; then
    mpi_row "11b -uniform_samples 16" 0 -input "$SCENE11" -shadows -bounces 1 -weight 0.01 \
        -grid 40 10 40 -size 1920 1080 -threads 1 -uniform_samples 16
fi
echo "   load at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
echo ""
