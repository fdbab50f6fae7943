#!/bin/sh
# Remakes the golden images of tests/golden/LIST with ./raytracer (run from the
# repository root). Only after a deliberate change of the pictures: look at every
# image before committing it.
set -e
grep -v '^#' tests/golden/LIST | while read -r name scene args; do
    [ -n "$name" ] || continue
    # shellcheck disable=SC2086
    ./raytracer -input "$scene" -output "tests/golden/$name.tga" $args
done
