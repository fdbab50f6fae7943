#!/usr/bin/env bash
# `make valgrind`: memcheck on a subset that fits CI (a few minutes): the binary on the
# project's scenes with every output, the grid and its visualisation, shadows, bounces,
# meshes and textures, bad input, and the image unit tests (test children end with
# _exit, so most unit tests keep their fixtures reachable by design). Any error, any
# leak, any block still reachable at exit fails.
set -u
bin=${RT_BIN:-./raytracer}
tests=${RT_TESTS:-build/tests}
out=$(mktemp -d "${TMPDIR:-/tmp}/rt_valgrind.XXXXXX")
trap 'rm -rf "$out"' EXIT
vg=(valgrind -q --error-exitcode=99 --leak-check=full --show-leak-kinds=all
    --errors-for-leak-kinds=all --suppressions=tests/valgrind.supp)
failed=0 n=0
check() { # check NAME EXPECTED_STATUS ARGS...
    local name=$1 want=$2
    shift 2
    n=$((n + 1))
    "${vg[@]}" "$@" >"$out/log" 2>&1
    local st=$?
    if [ $st -ne "$want" ]; then
        echo "valgrind $name: exit $st, expected $want"
        sed 's/^/    /' "$out/log" | head -40
        failed=$((failed + 1))
    else
        echo "valgrind $name: ok"
    fi
}
check showcase 0 "$bin" -input scenes/showcase.txt -size 24 18 -output "$out/a.tga" \
    -depth 5 20 "$out/d.tga" -normals "$out/n.ppm" -shadows -bounces 3 -weight 0.01 \
    -grid auto -stats -threads 2
check mesh_transform 0 "$bin" -input scenes/feat_mesh_transform.txt -size 20 20 \
    -output "$out/b.png" -shadows -grid 8 8 8 -threads 2
check textures 0 "$bin" -input scenes/tex_nested.txt -size 20 20 -output "$out/c.tga" -shadows
check visualize_grid 0 "$bin" -input scenes/feat_sphere_grid.txt -size 20 20 \
    -output "$out/v.tga" -grid 6 6 6 -visualize_grid
check refraction 0 "$bin" -input scenes/feat_refraction.txt -size 20 20 -output "$out/r.tga" \
    -shadows -bounces 5 -no_packets
# The same glass through the grid's packets (reflected and refracted rays as packets of
# the next depths), and point lights shaded in the packets' lanes.
check refraction_packets 0 "$bin" -input scenes/feat_refraction.txt -size 24 24 \
    -output "$out/p.tga" -shadows -shade_back -bounces 5 -grid 8 8 8 -threads 2
check point_lights 0 "$bin" -input scenes/feat_attenuation.txt -size 24 24 \
    -output "$out/q.tga" -shadows -bounces 2 -grid 8 8 8
# Antialiasing: moments (jittered 16 + Gaussian; the box 0.5 with uniform 9), the samples
# picture beside them, and a film that keeps its samples (random 4 + Gaussian 1.0) with
# the depth image. valgrind's CPU has no AVX-512: the AVX2 paths run.
check antialias_moments 0 "$bin" -input scenes/showcase.txt -size 21 13 -output "$out/s.tga" \
    -jittered_samples 16 -gaussian_filter 0.4 -render_samples "$out/sp.tga" 3 -shadows \
    -grid auto -threads 2
check antialias_box 0 "$bin" -input scenes/showcase.txt -size 21 13 -output "$out/u.tga" \
    -uniform_samples 9 -shadows
check antialias_samples 0 "$bin" -input scenes/showcase.txt -size 21 13 -output "$out/w.tga" \
    -random_samples 4 -gaussian_filter 1.0 -depth 5 20 "$out/wd.tga" -grid auto
check bad_scene 1 "$bin" -input tests/bad/missing_brace.txt -output "$out/x.tga"
check bad_obj 1 "$bin" -input tests/bad/obj_bad_index.txt -output "$out/x.tga"
check usage 2 "$bin" -input scenes/showcase.txt -grid 0 0 0
check unit_image 0 "$tests/unit/test_image"
echo "make valgrind: $n runs, $failed failed"
[ $failed -eq 0 ]
