#!/bin/bash
# The benchmark driver behind `make bench` (docs/benchmarks.md): (a) the course suite, wall
# and CPU per line; (b) trace throughput, primary and shadow rays, 1 and 2 threads, on
# the bunny scenes and a 1.3M-triangle mesh; (c) set-up costs; (d) the same rays through
# Embree (bench/embree_ref.c), paired with ours. Writes bench/REPORT.txt.
# Environment: RT_BIN, RT_TOOLS (build/tools), EMBREE_REF (empty: no pairing), GRID_REF
# (bench/grid_ref.c built: our traversal alone, traced like embree_ref traces Embree),
# BENCH_RUNS (median of N, default 3), BENCH_QUICK=1 (bunny 40k and the blob only, no
# brute-force column), BENCH_BRUTE=0 (no brute-force column), BENCH_BRUTE_LIMIT (seconds
# per brute-force run, default 20), RT_COURSE (default
# ../shared/course), RT_MPI_BIN (raytracer-mpi for section (h), default ./raytracer-mpi),
# BENCH_REPORT (output file, default bench/REPORT.txt).
set -u
export LC_ALL=C
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BIN=${RT_BIN:-$ROOT/raytracer}
TOOLS=${RT_TOOLS:-$ROOT/build/tools}
EMB=${EMBREE_REF:-}
GREF=${GRID_REF:-$ROOT/build/bench/grid_ref}
RUNS=${BENCH_RUNS:-3}
QUICK=${BENCH_QUICK:-0}
BRUTE=${BENCH_BRUTE:-1}
BRUTE_LIMIT=${BENCH_BRUTE_LIMIT:-20}
[ "$QUICK" = 1 ] && BRUTE=0
COURSE=${RT_COURSE:-$ROOT/../shared/course}
OUT=$ROOT/bench/out
REPORT=${BENCH_REPORT:-$ROOT/bench/REPORT.txt}
mkdir -p "$OUT" || exit 1
TMP=$(mktemp -d "${TMPDIR:-/tmp}/rt_bench.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT
R=$TMP/report.txt
: >"$R"

say() { printf '%s\n' "$*" | tee -a "$R"; }
note() { printf '%s\n' "$*" >&2; }

[ -x "$BIN" ] || { echo "bench: no raytracer at $BIN (run make)" >&2; exit 1; }
[ -n "$EMB" ] && [ ! -x "$EMB" ] && { echo "bench: no $EMB; running without Embree" >&2; EMB=; }
# Run private copies: a rebuild in the work tree during the run must not swap binaries.
cp "$BIN" "$TMP/raytracer" && BIN=$TMP/raytracer || exit 1
if [ -n "$EMB" ]; then cp "$EMB" "$TMP/embree_ref" && EMB=$TMP/embree_ref || exit 1; fi
if [ -x "$GREF" ]; then cp "$GREF" "$TMP/grid_ref" && GREF=$TMP/grid_ref || exit 1; else
    note "bench: no $GREF (make grid_ref): no traversal-only column"; GREF=; fi


# median of the arguments (numbers)
median() {
    printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END {
        if (NR == 0) print "nan"; else if (NR % 2) print a[(NR + 1) / 2];
        else printf "%.3f\n", (a[NR / 2] + a[NR / 2 + 1]) / 2 }'
}
# arithmetic with awk: calc "expr" [decimals] (numbers only)
calc() { awk "BEGIN { printf \"%.${2:-2}f\", $1 }"; }
# div A B [decimals]: A / B, or "-" unless both are numbers and B > 0
div() {
    awk -v a="$1" -v b="$2" -v d="${3:-2}" 'BEGIN {
        if (a !~ /^[0-9.eE+-]+$/ || b !~ /^[0-9.eE+-]+$/ || b + 0 <= 0) print "-";
        else printf "%.*f", d, a / b }'
}

# run_timed CMD...: runs once, sets WALL CPU (ms) and leaves stdout/stderr in
# $TMP/run.out $TMP/run.err; STATUS = exit status.
run_timed() {
    local TIMEFORMAT='%R %U %S' t
    { time "$@" >"$TMP/run.out" 2>"$TMP/run.err"; STATUS=$?; } 2>"$TMP/time.txt"
    t=$(tail -n 1 "$TMP/time.txt")
    WALL=$(echo "$t" | awk '{ printf "%.1f", $1 * 1000 }')
    CPU=$(echo "$t" | awk '{ printf "%.1f", ($2 + $3) * 1000 }')
}
# from the last run: -timings phase (parse|render|write, or the accelerator's build:
# grid|twolevel, absent without one) in ms, or nan; $1 is an extended regex
timing() { sed -En "s/.*timings:.* ($1) ([0-9.]*) ms.*/\2/p" "$TMP/run.err" | tail -n 1 | grep . || echo nan; }
# from the last run: a -stats counter by label ("num shadow rays")
stat_of() { sed -n "s/^  $1  *\([0-9.]*\).*/\1/p" "$TMP/run.out" | tail -n 1 | grep . || echo 0; }
# from the last embree_ref run: key=value
emb_of() { tr ' ' '\n' <"$TMP/run.out" | sed -n "s/^$1=//p" | head -n 1; }

# BENCH_ONLY=letters: only those sections (a b c e f g h; b includes d), e.g. BENCH_ONLY=e
want() { case "${BENCH_ONLY:-abcefgh}" in *"$1"*) return 0 ;; esac; return 1; }

HAS_TIMINGS=0
"$BIN" -h 2>&1 | grep -q -- '-timings' && HAS_TIMINGS=1
TIMINGS=
[ "$HAS_TIMINGS" = 1 ] && TIMINGS=-timings

cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n 1)
commit=$(cd "$ROOT" && git rev-parse HEAD 2>/dev/null || echo unknown)
dirty=$(cd "$ROOT" && git status --porcelain --untracked-files=no 2>/dev/null | grep -q . && echo " (work tree has uncommitted changes)")
say "raytracer benchmark report (make bench; docs/benchmarks.md)"
say "date      $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
say "commit    $commit$dirty"
say "machine   $(nproc) cores, $cpu"
say "load      $(cut -d' ' -f1-3 /proc/loadavg) (1/5/15-min load average at the start)"
say "runs      median of $RUNS per figure; times are wall-clock unless marked CPU"
if [ -n "$EMB" ]; then
    say "embree    bench/embree_ref, Embree $(dpkg-query -W -f='${Version}' libembree-dev 2>/dev/null || echo '?')"
else
    say "embree    not built (apt-get install libembree-dev, then make bench)"
fi
say ""

# ---------------------------------------------------------------------------------
# (a) the course suite
# ---------------------------------------------------------------------------------
if want a && [ -f "$COURSE/commands.txt" ]; then
    say "== (a) course suite: $COURSE/commands.txt (outputs into a temporary folder)"
    say "   wall/cpu: whole process, ms; parse (incl. OBJ load), grid build, render: from -timings"
    if [ "$BRUTE" = 1 ]; then
        say "   brute: the same line without -grid, one run (only for grid lines that render),"
        say "   stopped after $BRUTE_LIMIT s (BENCH_BRUTE_LIMIT): whole-process wall ms and"
        say "   render ms; speedup = brute / grid, of the wall times (wall-x) and of the"
        say "   render times (rend-x, what the grid accelerates)"
    fi
    hdr=$(printf '   %-4s %8s %8s %7s %7s %8s %9s %9s %7s %7s' id wall cpu parse grid render \
        brute b-rend wall-x rend-x)
    say "$hdr"
    tot_wall=0 tot_cpu=0
    while IFS='|' read -r id args; do
        case "$id" in '#'* | '') continue ;; esac
        # rewrite -input/-output to absolute paths; -gui lines cannot run unattended
        set -- $args
        argv=() skip=0 has_grid=0 vis=0
        while [ $# -gt 0 ]; do
            case "$1" in
            -input) argv+=(-input "$COURSE/$2"); shift 2 ;;
            -output) argv+=(-output "$TMP/$2"); shift 2 ;;
            -gui) skip=1; shift ;;
            -grid) has_grid=1; argv+=("$1"); shift ;;
            -visualize_grid) vis=1; argv+=("$1"); shift ;;
            *) argv+=("$1"); shift ;;
            esac
        done
        if [ "$skip" = 1 ]; then
            say "$(printf '   %-4s (skipped: -gui)' "$id")"
            continue
        fi
        walls=() cpus=() parses=() grids=() renders=()
        for ((k = 0; k < RUNS; k++)); do
            run_timed "$BIN" "${argv[@]}" $TIMINGS
            if [ "$STATUS" != 0 ]; then
                note "bench: line $id failed (exit $STATUS): $(head -c 300 "$TMP/run.err")"
                break
            fi
            walls+=("$WALL") cpus+=("$CPU")
            parses+=("$(timing parse)") grids+=("$(timing 'grid|twolevel')") renders+=("$(timing render)")
        done
        if [ "$STATUS" != 0 ]; then
            say "$(printf '   %-4s FAILED (exit %s)' "$id" "$STATUS")"
            continue
        fi
        w=$(median "${walls[@]}") c=$(median "${cpus[@]}")
        tot_wall=$(calc "$tot_wall + $w" 1) tot_cpu=$(calc "$tot_cpu + $c" 1)
        brute=- speed=- brend=- rspeed=-
        r=$(median "${renders[@]}")
        if [ "$BRUTE" = 1 ] && [ "$has_grid" = 1 ] && [ "$vis" = 0 ]; then
            # the same line without "-grid nx ny nz"
            nog=() i=0
            while [ $i -lt ${#argv[@]} ]; do
                if [ "${argv[$i]}" = -grid ]; then i=$((i + 4)); continue; fi
                nog+=("${argv[$i]}"); i=$((i + 1))
            done
            run_timed timeout "$BRUTE_LIMIT" "$BIN" "${nog[@]}" $TIMINGS
            if [ "$STATUS" = 124 ]; then
                brute=">$((BRUTE_LIMIT * 1000))"
                speed=">$(div "$((BRUTE_LIMIT * 1000))" "$w" 0)x"
                brend=">$((BRUTE_LIMIT * 1000))"
                rspeed=">$(div "$((BRUTE_LIMIT * 1000))" "$r" 0)x"
            else
                brute=$WALL
                speed=$(div "$brute" "$w" 1)x
                brend=$(timing render)
                rspeed=$(div "$brend" "$r" 1)x
            fi
        fi
        say "$(printf '   %-4s %8s %8s %7s %7s %8s %9s %9s %7s %7s' "$id" "$w" "$c" \
            "$(median "${parses[@]}")" "$(median "${grids[@]}")" "$r" \
            "$brute" "$brend" "$speed" "$rspeed")"
    done <"$COURSE/commands.txt"
    say "   total: wall $tot_wall ms, cpu $tot_cpu ms (sum of the medians)"
    say ""
elif want a; then
    say "== (a) course suite: SKIPPED ($COURSE/commands.txt not found; set RT_COURSE)"
    say ""
fi

# ---------------------------------------------------------------------------------
# (b)+(d) trace throughput, ours and Embree's, paired
# ---------------------------------------------------------------------------------
if want b || want c; then
if [ ! -f "$OUT/blob.obj" ]; then
    note "bench: generating bench/out/blob.obj (modelgen blob 8: 1,310,720 triangles)"
    "$TOOLS/modelgen" -o "$OUT/blob.obj" blob 8 || exit 1
fi

# name|scene|grid args|depth range (for the hit cross-check with Embree)
cases=()
if [ -f "$COURSE/commands.txt" ]; then
    if [ "$QUICK" != 1 ]; then
        cases+=("bunny200|$COURSE/scene6_04_bunny_mesh_200.txt|-grid 10 10 7|0.6 1.2")
        cases+=("bunny1k|$COURSE/scene6_05_bunny_mesh_1k.txt|-grid 15 15 12|0.6 1.2")
        cases+=("bunny5k|$COURSE/scene6_06_bunny_mesh_5k.txt|-grid 20 20 15|0.6 1.2")
    fi
    cases+=("bunny40k|$COURSE/scene6_07_bunny_mesh_40k.txt|-grid 40 40 33|0.6 1.2")
    cases+=("bunny40k/auto|$COURSE/scene6_07_bunny_mesh_40k.txt|-grid auto|0.6 1.2")
fi
cases+=("blob1.3M|$ROOT/bench/blob.txt|-grid auto|4 9")
fi

if want b; then
say "== (b) trace throughput (Mrays/s) with (d) Embree on the same rays"
say "   render: the raytracer, render time from -timings (shading included, image"
say "   writing excluded); primary = W*H / render time without -shadows; shadow = shadow"
say "   rays / (render time with -shadows minus without)."
say "   trav: bench/grid_ref, our grid's traversal alone (8x8-ray packets, as the renderer"
say "   casts them), traced exactly like Embree's: same camera, rays, light directions"
say "   and epsilon, nothing shaded. Embree: bench/embree_ref, traversal only;"
say "   single = rtcIntersect1/rtcOccluded1, packet = rtcIntersect16/rtcOccluded16 on 4x4"
say "   pixel tiles. ratio = trav / Embree single."
hdr=$(printf '   %-14s %-9s %2s %7s %7s %7s %7s %7s %7s %7s %7s %6s %6s' case size th \
    rnd-p rnd-s trav-p trav-s embS-p embS-s embP-p embP-s "p/S" "s/S")
say "$hdr"
rm -f "$TMP/ratios.txt"
for c in "${cases[@]}"; do
    IFS='|' read -r name scene gridargs drange <<<"$c"
    if [ -n "$EMB" ]; then
        # Same rays? Both depth images of the primary hits, compared pixel by pixel.
        "$BIN" -input "$scene" -size 200 200 $gridargs -depth $drange "$TMP/d_ours.tga" >/dev/null 2>&1
        "$EMB" -input "$scene" -size 200 200 -depth $drange "$TMP/d_emb.tga" >/dev/null 2>&1
        same=$("$TOOLS/imgdiff" -t 1 "$TMP/d_ours.tga" "$TMP/d_emb.tga" 2>/dev/null |
            sed -n 's/^within 1\/255 *\([0-9.]*%\).*/\1/p' | head -n 1)
        echo "   $name: primary hits, depth images ours vs Embree at 200x200: ${same:-?} of pixels within 1/255" >>"$TMP/notes.txt"
    fi
    for size in "200 200" "1920 1080"; do
        for th in 1 2; do
            prs=() sh=() shadow_rays=0
            for ((k = 0; k < RUNS; k++)); do
                run_timed "$BIN" -input "$scene" -output "$TMP/o.tga" -size $size $gridargs \
                    -threads $th -stats $TIMINGS
                r0=$(timing render)
                [ "$STATUS" = 0 ] || { note "bench: $name failed: $(head -c 300 "$TMP/run.err")"; break; }
                [ "$r0" = nan ] && r0=$WALL
                run_timed "$BIN" -input "$scene" -output "$TMP/o.tga" -size $size $gridargs \
                    -threads $th -stats -shadows $TIMINGS
                r1=$(timing render)
                [ "$r1" = nan ] && r1=$WALL
                shadow_rays=$(stat_of "num shadow rays")
                prs+=("$r0") sh+=("$r1")
            done
            [ "$STATUS" = 0 ] || continue
            set -- $size
            px=$(($1 * $2))
            r0=$(median "${prs[@]}") r1=$(median "${sh[@]}")
            ours_p=$(div "$px" "$(calc "$r0 * 1000" 3)" 2)
            ours_s=$(div "$shadow_rays" "$(calc "($r1 - $r0) * 1000" 3)" 2)
            tr_p=- tr_s=-
            if [ -n "$GREF" ]; then
                run_timed "$GREF" -input "$scene" -size $size $gridargs -threads $th \
                    -mode packet -repeat "$RUNS" -shadows
                tr_p=$(emb_of primary_mrays) tr_s=$(emb_of shadow_mrays)
                tr_rays=$(emb_of shadow_rays)
            fi
            es_p=- es_s=- ep_p=- ep_s=- rp=- rs=- emb_rays=
            if [ -n "$EMB" ]; then
                run_timed "$EMB" -input "$scene" -size $size -threads $th -mode single \
                    -repeat "$RUNS" -shadows
                es_p=$(emb_of primary_mrays) es_s=$(emb_of shadow_mrays)
                emb_rays=$(emb_of shadow_rays)
                run_timed "$EMB" -input "$scene" -size $size -threads $th -mode packet \
                    -repeat "$RUNS" -shadows
                ep_p=$(emb_of primary_mrays) ep_s=$(emb_of shadow_mrays)
                rp=$(div "$tr_p" "$es_p") rs=$(div "$tr_s" "$es_s")
                echo "$name $size $th $rp $rs $(div "$tr_p" "$ep_p") $(div "$tr_s" "$ep_s")" >>"$TMP/ratios.txt"
                if [ "$th" = 1 ] && [ "$emb_rays" != "$shadow_rays" ]; then
                    echo "   note: $name $1x$2: shadow rays ours $shadow_rays, Embree $emb_rays" >>"$TMP/notes.txt"
                fi
            fi
            say "$(printf '   %-14s %-9s %2s %7s %7s %7s %7s %7s %7s %7s %7s %6s %6s' "$name" "${1}x$2" \
                "$th" "$ours_p" "$ours_s" "$tr_p" "$tr_s" "$es_p" "$es_s" "$ep_p" "$ep_s" "$rp" "$rs")"
        done
    done
done
say "   columns: rnd = the renderer, trav = our traversal alone; embS = Embree single rays,"
say "   embP = Embree packets; p/S, s/S = trav / Embree single (primary, shadow). Against"
say "   Embree's packets (trav / embP):"
if [ -f "$TMP/ratios.txt" ]; then
    awk '{ printf "     %-14s %4sx%-5s %s threads: trav/packet primary %s, shadow %s\n", $1, $2, $3, $4, $7, $8 }' \
        "$TMP/ratios.txt" | tee -a "$R"
fi
[ -f "$TMP/notes.txt" ] && tee -a "$R" <"$TMP/notes.txt"
say "   (per core: divide the 2-thread figures by 2; the machine has $(nproc) cores)"
say ""
fi

# ---------------------------------------------------------------------------------
# (c) set-up costs; whole-program pairing of course line 07
# ---------------------------------------------------------------------------------
if want c; then
say "== (c) set-up costs (ms, median; -size 1 1 runs with -timings)"
say "$(printf '   %-14s %9s %9s %10s %12s %12s' case triangles parse grid emb-load emb-build)"
for c in "${cases[@]}"; do
    IFS='|' read -r name scene gridargs drange <<<"$c"
    ps=() gs=() els=() ebs=() tris=-
    for ((k = 0; k < RUNS; k++)); do
        run_timed "$BIN" -input "$scene" -output "$TMP/o.tga" -size 1 1 $gridargs $TIMINGS
        ps+=("$(timing parse)") gs+=("$(timing 'grid|twolevel')")
        if [ -n "$EMB" ]; then
            run_timed "$EMB" -input "$scene" -size 1 1 -threads 1
            els+=("$(emb_of load_ms)") ebs+=("$(emb_of build_ms)")
            tris=$(emb_of triangles)
        fi
    done
    el=- eb=-
    [ -n "$EMB" ] && el=$(median "${els[@]}") eb=$(median "${ebs[@]}")
    say "$(printf '   %-14s %9s %9s %10s %12s %12s' "$name" "$tris" "$(median "${ps[@]}")" \
        "$(median "${gs[@]}")" "$el" "$eb")"
done
say "   parse includes reading the OBJ file; emb-load is the same parser (embree_ref uses"
say "   scene_load), emb-build is Embree's BVH build with 1 thread."
say ""

if [ -f "$COURSE/scene6_07_bunny_mesh_40k.txt" ]; then
    say "== whole program, course line 07 (-size 200 200 -grid 40 40 33 -stats -shadows), wall ms"
    s07=$COURSE/scene6_07_bunny_mesh_40k.txt
    ow=() esw=() epw=()
    for ((k = 0; k < RUNS; k++)); do
        run_timed "$BIN" -input "$s07" -output "$TMP/o.tga" -size 200 200 -grid 40 40 33 -stats -shadows
        ow+=("$WALL")
        if [ -n "$EMB" ]; then
            run_timed "$EMB" -input "$s07" -size 200 200 -threads "$(nproc)" -mode single -shadows
            esw+=("$WALL")
            run_timed "$EMB" -input "$s07" -size 200 200 -threads "$(nproc)" -mode packet -shadows
            epw+=("$WALL")
        fi
    done
    o=$(median "${ow[@]}")
    if [ -n "$EMB" ]; then
        es=$(median "${esw[@]}") ep=$(median "${epw[@]}")
        say "   ours $o, Embree single $es, Embree packets $ep; ours/Embree single $(div "$o" "$es"), ours/packets $(div "$o" "$ep")"
        say "   (both processes parse with our scene parser and use all cores; ours also"
        say "    shades and writes the image)"
    else
        say "   ours $o"
    fi
    say ""
fi
fi

# ---------------------------------------------------------------------------------
# (e) uneven scenes: whole process, ours (-grid auto) against Embree single rays
# ---------------------------------------------------------------------------------
# The scenes are made by tools/modelgen into bench/out (the bunny is linked from the
# course folder): stadium = the 40k bunny in a room 100x its size (floor and 66 wall
# triangles), clusters = 8 blobs of 5,120 triangles far apart, row = 48 blobs of 1,280
# triangles in a row 480 long.
if want e && [ -f "$COURSE/bunny_40k.obj" ]; then
    ln -sfn "$COURSE/bunny_40k.obj" "$OUT/bunny_40k.obj"
    [ -f "$OUT/room.obj" ] || "$TOOLS/modelgen" -q -o "$OUT/room.obj" room 31 33 0.06 || exit 1
    [ -f "$OUT/clusters.obj" ] || "$TOOLS/modelgen" -q -o "$OUT/clusters.obj" clusters 8 4 60 2 || exit 1
    [ -f "$OUT/row.obj" ] || "$TOOLS/modelgen" -q -o "$OUT/row.obj" row 48 3 480 || exit 1
    say "== (e) uneven scenes, whole process (parse, build, trace; ours also shades and writes),"
    say "   200x200 -shadows, paired runs interleaved (ours, Embree, uniform), median of $RUNS."
    say "   ours: -grid auto (two-level where crowded); uniform: the uniform grid -grid auto"
    say "   chose before (its resolution from grid_ref); Embree: embree_ref -mode single."
    say "   cpu = user + system CPU ms (steadier than wall on a shared machine); x = ours /"
    say "   Embree (target <= 1.5); tests = intersections per ray (-stats), ours / uniform."
    say "$(printf '   %-9s %2s %8s %8s %8s %8s %8s %8s %6s %6s %9s %9s' scene th wall emb-w uni-w cpu emb-c uni-c x-wall x-cpu tests uni-tests)"
    for sc in stadium clusters row; do
        scene=$ROOT/bench/$sc.txt
        udims=
        if [ -n "$GREF" ]; then
            run_timed "$GREF" -input "$scene" -size 1 1 -grid auto
            udims=$(tr ' ' '\n' <"$TMP/run.out" | sed -n 's/^cells=//p' | tr x ' ')
        fi
        for th in 1 2; do
            ow=() oc=() ew=() ec=() uw=() uc=()
            otests=- utests=-
            for ((k = 0; k < RUNS; k++)); do
                run_timed "$BIN" -input "$scene" -output "$TMP/o.tga" -size 200 200 -grid auto -shadows -threads $th -stats
                [ "$STATUS" = 0 ] || { note "bench: $sc failed: $(head -c 300 "$TMP/run.err")"; break; }
                ow+=("$WALL") oc+=("$CPU") otests=$(stat_of "intersections per ray")
                if [ -n "$EMB" ]; then
                    run_timed "$EMB" -input "$scene" -size 200 200 -threads $th -mode single -shadows
                    ew+=("$WALL") ec+=("$CPU")
                fi
                if [ -n "$udims" ]; then
                    run_timed "$BIN" -input "$scene" -output "$TMP/u.tga" -size 200 200 -grid $udims -shadows -threads $th -stats
                    uw+=("$WALL") uc+=("$CPU") utests=$(stat_of "intersections per ray")
                    cmp -s "$TMP/o.tga" "$TMP/u.tga" || note "bench: $sc: -grid auto and the uniform grid differ"
                fi
            done
            [ "$STATUS" = 0 ] || continue
            w=$(median "${ow[@]}") c=$(median "${oc[@]}")
            e_w=- e_c=- u_w=- u_c=-
            [ ${#ew[@]} -gt 0 ] && e_w=$(median "${ew[@]}") e_c=$(median "${ec[@]}")
            [ ${#uw[@]} -gt 0 ] && u_w=$(median "${uw[@]}") u_c=$(median "${uc[@]}")
            say "$(printf '   %-9s %2s %8s %8s %8s %8s %8s %8s %6s %6s %9s %9s' "$sc" "$th" "$w" "$e_w" "$u_w" "$c" "$e_c" "$u_c" "$(div "$w" "$e_w")" "$(div "$c" "$e_c")" "$otests" "$utests")"
        done
    done
    say ""
fi

# ---------------------------------------------------------------------------------
# (g) bounded grid builds: the cell-reference cap and -grid auto from object sizes
# ---------------------------------------------------------------------------------
# colocated = 10,000 spheres at one point (tests/repro); shards = 100,000 triangles with
# vertices anywhere in a cube (modelgen shards: large, all overlapping); bigmesh = 10
# blobs of 327,680 triangles in a row (modelgen row 10 7 40: 3,276,800 triangles, a
# 130 MB OBJ made once into bench/out). Per run: the grid phase of -timings (wall ms),
# the whole process's CPU ms and peak memory (GNU time's maximum resident set, MB), the
# resolution built and its cell references; "no grid" is the same run without one.
if want g; then
    [ -f "$OUT/shards.obj" ] || "$TOOLS/modelgen" -q -o "$OUT/shards.obj" shards 100000 || exit 1
    [ -f "$OUT/bigmesh.obj" ] || "$TOOLS/modelgen" -q -o "$OUT/bigmesh.obj" row 10 7 40 || exit 1
    GTIME=
    [ -x /usr/bin/time ] && GTIME=/usr/bin/time
    say "== (g) bounded grid builds, -size 20 20 -shadows, median of $RUNS (grid ms: -timings;"
    say "   cpu: whole process, user + system; rss: peak resident MB, GNU time; refs: cell"
    say "   references built, marching / course, and the cap)"
    say "$(printf '   %-10s %-14s %9s %9s %7s %-13s %s' scene grid grid-ms cpu-ms rss-MB cells refs)"
    for row in "colocated|$ROOT/tests/repro/grid_auto_colocated_10000.txt" \
               "shards|$ROOT/bench/shards.txt" "bigmesh|$ROOT/bench/bigmesh.txt"; do
        sc=${row%%|*} scene=${row#*|}
        for g in none "auto" "64 64 64" "40 40 40"; do
            [ "$sc" = bigmesh ] && [ "$g" = "64 64 64" ] && continue
            [ "$sc" != bigmesh ] && [ "$g" = "40 40 40" ] && continue
            gargs=()
            [ "$g" != none ] && gargs=(-grid $g)
            gm=() cm=() rs=()
            cells=- refs=-
            for ((k = 0; k < RUNS; k++)); do
                if [ -n "$GTIME" ]; then
                    run_timed "$GTIME" -f 'rss_kb=%M' "$BIN" -input "$scene" -output "$TMP/g.tga" \
                        -size 20 20 -shadows -timings "${gargs[@]}"
                    rs+=("$(sed -n 's/^rss_kb=//p' "$TMP/run.err" | tail -n 1 | awk '{ printf "%.1f", $1 / 1024 }')")
                else
                    run_timed "$BIN" -input "$scene" -output "$TMP/g.tga" -size 20 20 -shadows -timings "${gargs[@]}"
                fi
                [ "$STATUS" = 0 ] || { note "bench: $sc -grid $g failed: $(head -c 300 "$TMP/run.err")"; break; }
                gm+=("$(timing 'grid|twolevel')") cm+=("$CPU")
                cells=$(sed -n 's/.*using \([0-9x]*\) instead.*/\1/p; s/.*auto chose \([0-9]*\) x \([0-9]*\) x \([0-9]*\) cells.*/\1x\2x\3/p' "$TMP/run.err" | head -n 1)
                [ -z "$cells" ] && [ "$g" != none ] && cells=$(echo "$g" | tr ' ' x)
                [ "$g" = none ] && cells=-
                refs=$(sed -n 's/.*cell references: \([0-9]*\) marching, \([0-9]*\) course.*(cap \([0-9]*\)).*/\1 \/ \2, cap \3/p' "$TMP/run.err" | head -n 1)
                [ -z "$refs" ] && refs=-
            done
            [ "$STATUS" = 0 ] || continue
            rss=-
            [ ${#rs[@]} -gt 0 ] && rss=$(median "${rs[@]}")
            say "$(printf '   %-10s %-14s %9s %9s %7s %-13s %s' "$sc" "$g" "$(median "${gm[@]}")" "$(median "${cm[@]}")" "$rss" "$cells" "$refs")"
        done
    done
    say ""
fi

# (f) antialiasing: 16 samples against 1 (bench/aa.sh)
if want f && [ -f "$COURSE/scene6_07_bunny_mesh_40k.txt" ]; then
    bash "$ROOT/bench/aa.sh" "$BIN" "$COURSE" "$RUNS" | tee -a "$R"
fi

# (h) split renders: 64 tiles against one render, raytracer-mpi -np 1/2/4 (bench/dist.sh)
if want h && [ -f "$COURSE/scene6_07_bunny_mesh_40k.txt" ] && [ "$QUICK" != 1 ]; then
    bash "$ROOT/bench/dist.sh" "$BIN" "${RT_MPI_BIN:-$ROOT/raytracer-mpi}" "$COURSE" "$RUNS" | tee -a "$R"
fi

mv "$R" "$REPORT.tmp" && mv "$REPORT.tmp" "$REPORT"
trap - EXIT
rm -rf "$TMP"
echo "bench: report written to $REPORT"
