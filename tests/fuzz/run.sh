#!/usr/bin/env bash
# Runs the libFuzzer targets built by `make fuzz` (mk/fuzz.mk):
#   run.sh BUILD_DIR SECONDS JOBS NAME...
# Each target gets a working corpus in BUILD_DIR/corpus/NAME, seeded from the course
# scenes (../shared/course, when present), the project's scenes, tests/bad, tests/repro,
# the committed seeds of tests/fuzz/seeds/NAME and the regression inputs of
# tests/fuzz/regress/NAME; a dictionary tests/fuzz/NAME.dict when there is one. Limits:
# 2 s per input, 2 GiB of memory; leaks are findings. Prints one line per target with
# its executions and exits 1 when any target found something (the input is kept in
# BUILD_DIR/artifacts/NAME/; copy it into tests/fuzz/regress/NAME/ once fixed).
set -u
build=$1 seconds=$2 jobs=$3
shift 3
root=$(pwd)
case $build in /*) ;; *) build=$root/$build ;; esac   # absolute: the targets change folder
max_seed=65536

seed() { # seed NAME FILE...: copies the small readable files into the corpus
    local dir=$build/corpus/$1
    shift
    local f
    for f in "$@"; do
        [ -f "$f" ] && [ "$(stat -c %s "$f")" -le $max_seed ] && cp -f "$f" "$dir/seed_$(basename "$f")"
    done
    return 0
}

# The course's command lines as NUL-separated argv (the cli target's input format).
cli_seeds() {
    local dir=$build/corpus/cli n=0 line
    for line in "-input scene.txt -output out.tga -size 100 100" \
                "-input s.txt -grid auto -stats -depth 9 11 d.tga -normals n.ppm" \
                "-h" "--version" "-input s.txt -grid 10 10 10 -visualize_grid -gui_keys r"; do
        printf '%s' "$line" | tr ' ' '\0' > "$dir/seed_line_$n"
        n=$((n + 1))
    done
    if [ -f ../shared/course/commands.txt ]; then
        grep -o -- '-input.*' ../shared/course/commands.txt | while read -r line; do
            printf '%s' "$line" | tr -s ' ' '\0' > "$dir/seed_course_$n"
            n=$((n + 1))
        done
    fi
}

prepare() {
    local name=$1
    mkdir -p "$build/corpus/$name" "$build/artifacts/$name"
    case $name in
    scene) seed scene ../shared/course/*.txt scenes/*.txt tests/bad/*.txt tests/repro/*.txt ;;
    obj)   seed obj ../shared/course/*.obj models/*.obj tests/bad/*.obj ;;
    cli)   cli_seeds ;;
    esac
    seed "$name" tests/fuzz/seeds/"$name"/* tests/fuzz/regress/"$name"/*
}

run_one() {
    local name=$1 log=$build/logs/$1.log dict=() max_len=16384
    case $name in
    obj) max_len=8192 ;;
    gui_keys|cli) max_len=2048 ;;
    esac
    [ -f "tests/fuzz/$name.dict" ] && dict=(-dict="$root/tests/fuzz/$name.dict")
    # -close_fd_mask=1: the targets' stdout (ray-tree lines) is noise; stderr stays.
    # The targets make their temporary folders here (removed afterwards).
    local tmp=$build/tmp/$name
    rm -rf "$tmp" && mkdir -p "$tmp"
    TMPDIR=$tmp "$build/fuzz/fuzz_$name" "${dict[@]}" -max_total_time="$seconds" -timeout=2 \
        -rss_limit_mb=2048 -malloc_limit_mb=2048 -max_len=$max_len -close_fd_mask=1 \
        -print_final_stats=1 -artifact_prefix="$build/artifacts/$name/" \
        "$build/corpus/$name" >"$log" 2>&1
    local st=$?
    rm -rf "$tmp"
    local execs
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    if [ $st -eq 0 ]; then
        printf 'fuzz %-9s ok      %12s executions in %s s\n' "$name" "${execs:-?}" "$seconds"
    else
        printf 'fuzz %-9s FAILED  %12s executions (exit %d; log %s; input in %s)\n' \
            "$name" "${execs:-?}" $st "$log" "$build/artifacts/$name/"
        grep -m 3 -E 'ERROR|SUMMARY|leak' "$log" | sed 's/^/    /'
    fi
    return $st
}

mkdir -p "$build/logs"
for name in "$@"; do prepare "$name"; done
failed=0 running=0
declare -A pids=()
for name in "$@"; do
    run_one "$name" &
    pids[$!]=$name
    running=$((running + 1))
    if [ $running -ge "$jobs" ]; then
        wait -n || failed=1
        running=$((running - 1))
    fi
done
while [ $running -gt 0 ]; do
    wait -n || failed=1
    running=$((running - 1))
done
if [ $failed -ne 0 ]; then
    echo "make fuzz: findings (see above)"
    exit 1
fi
echo "make fuzz: $# targets, no finding"
