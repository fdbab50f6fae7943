#!/bin/sh
# Renders the showcase and the feature scenes into demo/ (make demo; docs/demo-scenes-models.md).
# Usage: sh scenes/demo.sh /abs/path/to/raytracer [OUTDIR]
# Exit status 1 when any render fails (the others are still rendered).
set -u
BIN=${1:?usage: sh scenes/demo.sh /abs/path/to/raytracer [outdir]}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${2:-$ROOT/demo}
S=$ROOT/scenes
mkdir -p "$OUT" || exit 1
fail=0
count=0
# PNG, which any viewer shows, when the binary has it; TGA otherwise.
if "$BIN" --version 2>/dev/null | grep -q 'png yes'; then
    EXT=png
else
    EXT=tga
fi

# render NAME SCENE ARGS...: one image OUT/NAME.EXT; a line of the table with its time.
# The log keeps what the run printed (statistics, warnings) and goes when it is empty.
render() {
    name=$1 scene=$2
    shift 2
    count=$((count + 1))
    start=$(date +%s.%N)
    if "$BIN" -input "$S/$scene" -output "$OUT/$name.$EXT" "$@" >"$OUT/$name.log" 2>&1; then
        end=$(date +%s.%N)
        secs=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f", b - a }')
        printf '  %-30s %6s s   %s\n' "$name.$EXT" "$secs" "$*"
    else
        echo "  $name.$EXT FAILED (exit $?): $BIN -input $S/$scene $*" >&2
        sed 's/^/      /' "$OUT/$name.log" >&2
        fail=1
    fi
    [ -s "$OUT/$name.log" ] || rm -f "$OUT/$name.log"
}

echo "demo: rendering into $OUT ($EXT images)"
printf '  %-30s %8s   %s\n' "image" "time" "options"
# The showcase: every feature at once (docs/demo-scenes-models.md lists what is where).
# Antialiased: 16 jittered samples per pixel and a Gaussian filter (README.txt, 9).
render showcase showcase.txt -size 400 300 -shadows -shade_back -bounces 5 -weight 0.01 -grid auto -stats \
    -jittered_samples 16 -gaussian_filter 0.5
# The whole statistics block: from the line of asterisks before its title to the one
# after it (the log may also hold warnings).
[ -f "$OUT/showcase.log" ] && awk '/^\*+$/ { if (inside) { print; inside = 0; next } star = $0; next }
    /RAY TRACING STATISTICS/ { print star; inside = 1 } inside { print }' "$OUT/showcase.log"

render feat_ortho feat_ortho.txt -size 200 200 -shadows \
    -depth 8 12 "$OUT/feat_ortho_depth.$EXT" -normals "$OUT/feat_ortho_normals.$EXT"
render feat_transforms feat_transforms.txt -size 300 200 -shadows -grid auto
render feat_refraction feat_refraction.txt -size 300 200 -shadows -shade_back -bounces 8 -weight 0.01 -grid auto
render feat_shade_back feat_shade_back.txt -size 200 200 -shade_back -grid auto
render feat_no_shade_back feat_shade_back.txt -size 200 200 -grid auto
render feat_attenuation feat_attenuation.txt -size 300 200 -shadows
render feat_planes feat_planes.txt -size 200 200 -shadows -bounces 2 -weight 0.01 -grid auto
render feat_mirrors feat_mirrors.txt -size 300 200 -shadows -bounces 10 -weight 0.01 -grid auto
render feat_nolights feat_nolights.txt -size 200 200 -grid auto
render feat_sphere_grid feat_sphere_grid.txt -size 200 200 -shadows -bounces 2 -weight 0.01 -grid 10 10 10
render feat_sphere_grid_cells feat_sphere_grid.txt -size 200 200 -grid 10 10 10 -visualize_grid
render feat_mesh_transform feat_mesh_transform.txt -size 300 200 -shadows -bounces 1 -weight 0.01 -grid auto
render feat_mesh_transform_cells feat_mesh_transform.txt -size 300 200 -grid 30 10 20 -visualize_grid

# The textures engineer's scenes, when present (scenes/tex_*.txt).
for f in "$S"/tex_*.txt; do
    [ -f "$f" ] || continue
    b=$(basename "$f" .txt)
    render "$b" "$b.txt" -size 300 300 -shadows -bounces 3 -weight 0.01 -grid auto
done

if [ "$fail" -ne 0 ]; then
    echo "demo: some renders FAILED (see above); the others are in $OUT" >&2
    exit 1
fi
if [ "$EXT" = png ]; then
    echo "demo: $count renders written to $OUT (PNG)"
else
    echo "demo: $count renders written to $OUT (TGA: built without libpng; e.g."
    echo "      'convert $OUT/showcase.tga showcase.png' shows one)"
fi
