#!/bin/sh
# A screenshot of a bench's index.html as a browser draws it (headless Chromium), for readers
# without the browser test (tests/bench_page_browser.rs).
#
# usage: scripts/bench-screenshot.sh BENCH_DIR OUT.png [WIDTH,HEIGHT]
#
# Needs chromium (Debian: apt-get install chromium). WIDTH,HEIGHT: the window, default
# 1400,2600 (the whole page of a bench of a few integrators).
set -eu
dir=${1:?usage: bench-screenshot.sh BENCH_DIR OUT.png [WIDTH,HEIGHT]}
out=${2:?usage: bench-screenshot.sh BENCH_DIR OUT.png [WIDTH,HEIGHT]}
size=${3:-1400,2600}
[ -f "$dir/index.html" ] || { echo "bench-screenshot.sh: no $dir/index.html" >&2; exit 2; }
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome) ||
    { echo "bench-screenshot.sh: no chromium on PATH (apt-get install chromium)" >&2; exit 2; }
page=$(cd "$dir" && pwd)/index.html
case $out in /*) ;; *) out=$PWD/$out ;; esac
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars --virtual-time-budget=3000 \
    --window-size="$size" --screenshot="$out" "file://$page" 2>/dev/null
[ -s "$out" ] || { echo "bench-screenshot.sh: chromium wrote no $out" >&2; exit 1; }
echo "$out"
