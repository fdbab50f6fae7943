#!/usr/bin/env bash
# `make tsan`: the threaded code under ThreadSanitizer (binaries of build-tsan/). The
# set-up helpers (rt/par.h), grid binning and OBJ pieces, the property test (ray
# packets against single rays), renders through the binary on 2 threads (tiles,
# packets, shadows, secondary-ray packets, point lights in packets, outputs streamed by
# the render threads, the per-thread statistics merge, an antialiased film), the OSMesa
# snapshot's render key and the GLUT window's background render under Xvfb. Any report
# fails.
set -u
bin=${RT_BIN:?}
tests=${RT_TESTS:?}
out=$(mktemp -d "${TMPDIR:-/tmp}/rt_tsan.XXXXXX")
trap 'rm -rf "$out"' EXIT
export TSAN_OPTIONS="halt_on_error=1 exitcode=66 second_deadlock_stack=1"
# Mesa's llvmpipe rasterises the preview on threads of its own inside swrast_dri.so,
# which is not instrumented: TSan cannot see that library's own synchronisation and
# reports races between its threads (a mutex destroyed in a draw call against one of
# its worker threads' locks), in about half of the window runs. One rasteriser thread
# (LP_NUM_THREADS=0) leaves only our threads to check; our render thread and the
# window's main thread are still both running.
export LP_NUM_THREADS=0
failed=0 n=0
check() { # check NAME ARGS...
    local name=$1
    shift
    n=$((n + 1))
    "$@" >"$out/log" 2>&1
    local st=$?
    if [ $st -ne 0 ] || grep -q "ThreadSanitizer" "$out/log"; then
        echo "tsan $name: exit $st"
        grep -A30 -m1 "WARNING: ThreadSanitizer\|FAIL" "$out/log" | sed 's/^/    /' | head -40
        failed=$((failed + 1))
    else
        echo "tsan $name: ok ($(tail -n 1 "$out/log"))"
    fi
}
check unit_setup_par "$tests/unit/test_setup_par"
check unit_setup_build "$tests/unit/test_setup_build"
check unit_obj_threads "$tests/unit/test_obj_threads"
check unit_grid_property "$tests/unit/test_grid_property"
check render_showcase "$bin" -input scenes/showcase.txt -size 64 48 -output "$out/a.tga" \
    -shadows -bounces 3 -grid auto -stats -threads 2
check render_mesh "$bin" -input scenes/feat_mesh_transform.txt -size 64 64 -output "$out/b.tga" \
    -shadows -grid 16 16 16 -threads 2
# Three outputs made and written band by band by the render threads (rt/image.h,
# image_encoding_stream), and -timings' course counts and estimate on the set-up threads.
check render_streamed "$bin" -input scenes/feat_mesh_transform.txt -size 64 64 \
    -output "$out/e.ppm" -depth 8 12 "$out/e_d.tga" -normals "$out/e_n.ppm" -shadows \
    -grid 16 16 16 -timings -threads 2
check render_no_grid "$bin" -input scenes/tex_nested.txt -size 48 48 -output "$out/c.tga" -threads 2
# Without -stats (which turns the packets off): reflected and refracted rays traced as
# packets of the next depths (glass, -bounces 4), and point lights shaded in the
# packets' lanes (each lane's direction and colour), with the depth limit chosen once.
check render_secondary "$bin" -input scenes/feat_refraction.txt -size 64 48 -output "$out/g.tga" \
    -shadows -shade_back -bounces 4 -grid 10 10 10 -threads 2
check render_point_lights "$bin" -input scenes/feat_attenuation.txt -size 64 48 \
    -output "$out/h.tga" -shadows -bounces 2 -grid 10 10 10 -threads 2
# Antialiasing: the sampler's batches, the Gaussian's per-sample weights and the film's
# bands, shared by the render threads.
check render_antialiased "$bin" -input scenes/showcase.txt -size 64 48 -output "$out/d.tga" \
    -jittered_samples 4 -gaussian_filter 0.4 -shadows -grid auto -threads 2
# 16 samples: the film keeps each pixel's moments, made by the band that traced it and
# read by the filter jobs of both threads.
check render_moments "$bin" -input scenes/showcase.txt -size 64 48 -output "$out/m.tga" \
    -jittered_samples 16 -gaussian_filter 0.4 -shadows -grid auto -threads 2
# The blend lanes (Marble over two flat Phong materials, every light directional: the
# packet shades them inline): a render thread's first blend packet reads the copy of
# blend_begin's eight-lane run that blend_choose picks once. Read before the thread's
# own pthread_once, it raced with another thread's pick (fixed 2026-11-27); the sphere
# fills the image so that both threads' first packets are blend packets. Three runs:
# one caught that race 5 times in 6 on the Zen 3 host.
cat >"$out/blend.txt" <<'SCENE'
PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }
Lights { numLights 1 DirectionalLight { direction -0.5 -0.5 -1 color 0.9 0.9 0.9 } }
Background { color 0.1 0.1 0.1 ambientLight 0.2 0.2 0.2 }
Materials {
    numMaterials 3
    PhongMaterial { diffuseColor 0.9 0.9 0.9 }
    PhongMaterial { diffuseColor 0.2 0.3 0.6 }
    Marble { materialIndex 0 materialIndex 1 octaves 4 frequency 2 amplitude 3 }
}
Group { numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 3.5 } }
SCENE
for run in 1 2 3; do
    check render_blend_$run "$bin" -input "$out/blend.txt" -size 48 48 -output "$out/f.tga" \
        -jittered_samples 4 -shadows -grid auto -threads 2
done
check preview_snapshots env RT_BIN="$bin" "$tests/unit/test_preview"
if command -v xvfb-run >/dev/null 2>&1; then
    check preview_window env RT_BIN="$bin" "$tests/e2e/test_gui_xvfb"
else
    echo "tsan preview_window: xvfb-run missing (apt-get install xvfb xauth)"
    failed=$((failed + 1))
fi
echo "make tsan: $n runs, $failed failed"
[ $failed -eq 0 ]
