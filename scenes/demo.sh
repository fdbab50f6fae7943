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

# render NAME SCENE ARGS...: one image OUT/NAME.tga; the time and status are printed.
render() {
    name=$1 scene=$2
    shift 2
    count=$((count + 1))
    start=$(date +%s.%N)
    if "$BIN" -input "$S/$scene" -output "$OUT/$name.tga" "$@" >"$OUT/$name.log" 2>&1; then
        end=$(date +%s.%N)
        secs=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f", b - a }')
        printf '  %-28s %6s s   %s\n' "$name.tga" "$secs" "$*"
    else
        echo "  $name.tga FAILED (exit $?): $BIN -input $S/$scene $*" >&2
        sed 's/^/      /' "$OUT/$name.log" >&2
        fail=1
    fi
}

echo "demo: rendering into $OUT"
# The showcase: every feature at once (docs/demo-scenes-models.md lists what is where).
# Antialiased: 16 jittered samples per pixel and a Gaussian filter (README.txt, 9).
render showcase showcase.txt -size 400 300 -shadows -shade_back -bounces 5 -weight 0.01 -grid auto -stats \
    -jittered_samples 16 -gaussian_filter 0.5
sed -n '/RAY TRACING STATISTICS/,/^\*/p' "$OUT/showcase.log"

render feat_ortho feat_ortho.txt -size 200 200 -shadows \
    -depth 8 12 "$OUT/feat_ortho_depth.tga" -normals "$OUT/feat_ortho_normals.tga"
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
echo "demo: $count images written to $OUT (TGA; e.g. 'convert $OUT/showcase.tga showcase.png')"
