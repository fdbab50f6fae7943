#!/bin/bash
# Instruction counts of two raytracer binaries on a fixed set of lines (docs/benchmarks.md,
# "Instruction counts"): callgrind counts every instruction the process executes, which
# on a shared machine is a steadier yardstick than wall time (the count of a line is
# the same from run to run to a few hundred instructions). Both binaries run the same
# command line, one after the other, at -threads 1; valgrind hides AVX-512, so both
# run their AVX2 kernels.
#
# Usage: bash bench/instructions.sh OLD_BINARY NEW_BINARY [COURSE_DIR]
#   RT_INSTR_ONLY=REGEX   run only the lines whose id matches (grep -E)
#   RT_INSTR_KEEP=DIR     keep the callgrind files as DIR/ID.old and DIR/ID.new, for
#                         callgrind_annotate (which function grew)
#   RT_INSTR_SIZE=N       image size of the course lines (default 64: N x N)
#   RT_INSTR_LIST=1       print the ids and command lines without running anything
# Prints one row a line: id, old and new counts, the change in percent, and "<<" where
# the new binary executes more than 1% more. The lines:
#   load_*   -size 1 1 renders of a mesh alone: the scene and OBJ reading (every OBJ of
#            the course and of models/, and the 40k bunny as CR LF, with a comment on
#            every line, with one glued to every line, and with a byte-order mark), and
#            a scene file of 10,000 spheres (tests/repro)
#   a6_*     every A6 course line (commands.txt) at N x N
#   a7_*     A7 lines with 16 samples (and the samples and filter pictures) at N x N
#   dn_*     -depth and -normals images; png_07 a PNG image; cam_* perspective eyes
#            near the origin, at 100 units and at 1000 (past CAMERA_FAR_EYE, 128,
#            where the far-eye aiming is meant to cost more)
set -u
export LC_ALL=C
OLD=${1:-} NEW=${2:-}
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(dirname "$HERE")
COURSE=${3:-${RT_COURSE:-$ROOT/../shared/course}}
SIZE=${RT_INSTR_SIZE:-64}
ONLY=${RT_INSTR_ONLY:-}
if [ -z "${RT_INSTR_LIST:-}" ]; then
    if [ -z "$OLD" ] || [ -z "$NEW" ] || [ ! -x "$OLD" ] || [ ! -x "$NEW" ]; then
        echo "usage: bash bench/instructions.sh OLD_BINARY NEW_BINARY [COURSE_DIR]" >&2
        exit 2
    fi
    command -v valgrind >/dev/null || { echo "instructions.sh: valgrind is not installed" >&2; exit 2; }
fi
[ -f "$COURSE/commands.txt" ] || { echo "instructions.sh: no course data in $COURSE" >&2; exit 2; }
COURSE=$(cd "$COURSE" && pwd)
TMP=$(mktemp -d "${TMPDIR:-/tmp}/rt_instr.XXXXXX") || exit 1
trap 'rm -rf "$TMP"' EXIT
KEEP=${RT_INSTR_KEEP:-}
[ -n "$KEEP" ] && mkdir -p "$KEEP"
# Private copies: a rebuild during the run changes nothing.
if [ -z "${RT_INSTR_LIST:-}" ]; then
    cp "$OLD" "$TMP/old" && cp "$NEW" "$TMP/new" || exit 1
fi

# A scene holding one mesh, for the loading lines (-size 1 1: one ray, so the count is
# the start, the scene and the OBJ file, and the grid-less set-up).
mesh_scene() { # $1 obj file name (relative to the scene's folder)
    cat <<EOF
PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }
Lights { numLights 1 DirectionalLight { direction 0 -1 -1 color 1 1 1 } }
Background { color 0 0 0 ambientLight 0.1 0.1 0.1 }
Materials { numMaterials 1 PhongMaterial { diffuseColor 0.8 0.8 0.8 } }
Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file $1 } }
EOF
}
# A bunny and a sphere seen from an eye at (X, X, X): the same view at any X.
cam_scene() { # $1 the eye's coordinates
    cat <<EOF
PerspectiveCamera { center $1 $1 $1 direction -0.5 -0.3 -0.8 up 0 1 0 angle 30 }
Lights { numLights 1 DirectionalLight { direction 0 -1 -1 color 1 1 1 } }
Background { color 0.1 0.1 0.3 ambientLight 0.1 0.1 0.1 }
Materials { numMaterials 1 PhongMaterial { diffuseColor 0.8 0.6 0.4 } }
Group { numObjects 2 MaterialIndex 0
  Transform { Translate $(($1 - 5)) $(($1 - 4)) $(($1 - 8)) Scale 10 10 10
    TriangleMesh { obj_file bunny_1k.obj } }
  Sphere { center $(($1 - 6)) $(($1 - 3)) $(($1 - 9)) radius 0.8 }
}
EOF
}

mkdir -p "$TMP/m" "$TMP/out"
IDS=() DIRS=() ARGS=()
add() { # id, working folder, arguments (one string, split at spaces)
    [ -n "$ONLY" ] && ! printf '%s\n' "$1" | grep -Eq -- "$ONLY" && return
    IDS+=("$1") DIRS+=("$2") ARGS+=("$3")
}
load_line() { # id, obj file (any path); the copy is made in $TMP/m
    local name=${1#load_}
    cp "$2" "$TMP/m/$name.obj"
    mesh_scene "$name.obj" > "$TMP/m/$name.txt"
    add "$1" "$TMP/m" "-input $name.txt -size 1 1 -output $TMP/out/$1.tga"
}
for f in "$COURSE"/*.obj; do load_line "load_$(basename "$f" .obj)" "$f"; done
for f in "$ROOT"/models/*.obj; do load_line "load_m_$(basename "$f" .obj)" "$f"; done
B40=$COURSE/bunny_40k.obj
sed 's/$/\r/' "$B40" > "$TMP/crlf.obj"
sed 's/$/ # c/' "$B40" > "$TMP/comment.obj"
sed 's/$/#c/' "$B40" > "$TMP/glued.obj"
{ printf '\357\273\277'; cat "$B40"; } > "$TMP/bom.obj"
for v in crlf comment glued bom; do load_line "load_40k_$v" "$TMP/$v.obj"; done
# A long scene file (10,000 spheres, 460 KB): the scene reader's lexer and parser.
REPRO=$ROOT/tests/repro/grid_auto_colocated_10000.txt
[ -f "$REPRO" ] && add load_scene_10k "$(dirname "$REPRO")" "-input $(basename "$REPRO") -size 1 1 -output $TMP/out/scene10k.tga"

# The course lines at SIZE x SIZE, their images into $TMP/out.
while IFS='|' read -r id rest; do
    case $id in '#'* | '') continue ;; esac
    a=$(printf '%s\n' "$rest" | sed -E "s/-size [0-9]+ [0-9]+/-size $SIZE $SIZE/; s#-output ([^ ]+)#-output $TMP/out/\\1#")
    add "a6_$id" "$COURSE" "$a"
done < "$COURSE/commands.txt"
A7=$COURSE/a7
if [ -f "$A7/commands.txt" ]; then
    while IFS='|' read -r id rest; do
        case $id in 01s_c | 01f_c | 02s_c | 02f_c | 02c | 02f | 02g | 02i | 04b | 05c) ;; *) continue ;; esac
        a=$(printf '%s\n' "$rest" | sed -E "s/-size ([0-9]+) [0-9]+/-size $SIZE $SIZE/; s#-(output|render_samples|render_filter) ([^ ]+)#-\\1 $TMP/out/\\2#")
        # the samples and filter pictures are small already: keep the course's 9 x 9
        case $id in 0?[sf]_*) a=$(printf '%s\n' "$rest" | sed -E "s#-(render_samples|render_filter) ([^ ]+)#-\\1 $TMP/out/\\2#") ;; esac
        add "a7_$id" "$A7" "$a"
    done < "$A7/commands.txt"
    add a7_03_j16 "$A7" "-input scene7_03_marble_vase.txt -size $SIZE $SIZE -output $TMP/out/a7_03.tga -grid 15 30 15 -shadows -jittered_samples 16 -gaussian_filter 0.4"
fi
add dn_07 "$COURSE" "-input scene6_07_bunny_mesh_40k.txt -size $SIZE $SIZE -output $TMP/out/dn07.tga -grid 40 40 33 -depth 0.5 1.5 $TMP/out/dn07d.tga -normals $TMP/out/dn07n.tga"
add dn_17 "$COURSE" "-input scene6_17_marble_vase.txt -size $SIZE $SIZE -output $TMP/out/dn17.tga -grid 15 30 15 -depth 5 15 $TMP/out/dn17d.tga -normals $TMP/out/dn17n.tga"
add png_07 "$COURSE" "-input scene6_07_bunny_mesh_40k.txt -size $SIZE $SIZE -output $TMP/out/png07.png -grid 40 40 33 -shadows"
mkdir -p "$TMP/c"
cp "$COURSE/bunny_1k.obj" "$TMP/c/"
for x in 10 100 1000; do
    cam_scene "$x" > "$TMP/c/cam$x.txt"
    add "cam_$x" "$TMP/c" "-input cam$x.txt -size $SIZE $SIZE -output $TMP/out/cam$x.tga -grid 16 16 16 -shadows"
done

if [ -n "${RT_INSTR_LIST:-}" ]; then
    for i in "${!IDS[@]}"; do printf '%-14s (in %s) %s\n' "${IDS[$i]}" "${DIRS[$i]}" "${ARGS[$i]}"; done
    exit 0
fi

count() { # binary, callgrind file, working folder, arguments...
    local bin=$1 file=$2 dir=$3
    shift 3
    (cd "$dir" && valgrind --tool=callgrind --callgrind-out-file="$file" "$bin" "$@" -threads 1 \
        >/dev/null 2>"$file.err")
    local n
    n=$(sed -n 's/^totals: *\([0-9]*\).*/\1/p' "$file" 2>/dev/null | head -n 1)
    echo "${n:-failed}"
}
printf '%-14s %15s %15s %9s\n' id old new change
worse=0
for i in "${!IDS[@]}"; do
    id=${IDS[$i]}
    # shellcheck disable=SC2206
    args=(${ARGS[$i]})
    o=$(count "$TMP/old" "$TMP/cg.old" "${DIRS[$i]}" "${args[@]}")
    n=$(count "$TMP/new" "$TMP/cg.new" "${DIRS[$i]}" "${args[@]}")
    if [ -n "$KEEP" ]; then
        cp "$TMP/cg.old" "$KEEP/$id.old" 2>/dev/null
        cp "$TMP/cg.new" "$KEEP/$id.new" 2>/dev/null
    fi
    if [ "$o" = failed ] || [ "$n" = failed ]; then
        printf '%-14s %15s %15s %9s\n' "$id" "$o" "$n" "-"
        continue
    fi
    pct=$(awk -v a="$o" -v b="$n" 'BEGIN { printf "%+.2f", 100 * (b - a) / a }')
    mark=$(awk -v a="$o" -v b="$n" 'BEGIN { print (b > a * 1.01) ? "<<" : "" }')
    [ -n "$mark" ] && worse=$((worse + 1))
    printf '%-14s %15s %15s %8s%% %s\n' "$id" "$o" "$n" "$pct" "$mark"
done
echo "${#IDS[@]} lines, $worse with more than 1% more instructions in the new binary"
