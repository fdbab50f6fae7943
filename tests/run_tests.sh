#!/bin/sh
# Runs every test binary given on the command line and adds up their closing lines
# ("N passed, N failed[, N skipped]"). A binary that dies without its closing line
# counts as one failure. Exit status 1 when anything failed.
passed=0 failed=0 skipped=0
for t in "$@"; do
    echo "== $t"
    out=$("$t" 2>&1)
    status=$?
    printf '%s\n' "$out"
    last=$(printf '%s\n' "$out" | tail -n 1)
    case "$last" in
    *" passed, "*" failed"*)
        p=$(echo "$last" | sed -n 's/^\([0-9]*\) passed.*/\1/p')
        f=$(echo "$last" | sed -n 's/.* \([0-9]*\) failed.*/\1/p')
        s=$(echo "$last" | sed -n 's/.* \([0-9]*\) skipped.*/\1/p')
        passed=$((passed + ${p:-0})); failed=$((failed + ${f:-0})); skipped=$((skipped + ${s:-0}))
        [ "$status" -ne 0 ] && [ "${f:-0}" -eq 0 ] && failed=$((failed + 1))
        ;;
    *)
        echo "   $t ended without its summary line (status $status)"
        failed=$((failed + 1))
        ;;
    esac
done
echo
if [ "$skipped" -gt 0 ]; then
    echo "$passed passed, $failed failed, $skipped skipped"
else
    echo "$passed passed, $failed failed"
fi
[ "$failed" -eq 0 ]
