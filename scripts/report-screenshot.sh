#!/usr/bin/env bash
# Makes docs/img/report.png, the picture of the report on the README's front page: runs the main job
# (studies/honeycomb.yaml, replayed from fixtures/honeycomb, no solver needed) into
# target/report-screenshot/, opens its report.html in headless Chromium and saves the top of the page,
# 1200 px wide, as a palette PNG.
#
# Needs: the Rust toolchain, Chromium (Debian: apt-get install chromium) and, to keep the picture
# small, pngquant (apt-get install pngquant; without it the PNG is kept as Chromium wrote it, several
# times larger). Run from anywhere: scripts/report-screenshot.sh
set -euo pipefail
cd "$(dirname "$0")/.."

out=target/report-screenshot
png=docs/img/report.png
width=1200
height=1800

browser=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$browser" ]; then
    echo "report-screenshot: no chromium on PATH (Debian: apt-get install chromium)" >&2
    exit 2
fi

# The main job, replayed from its recordings whatever is on PATH, into a fresh directory.
rm -rf "$out"
cargo run --release --quiet -- run studies/honeycomb.yaml --out "$out" --replay fixtures/honeycomb >/dev/null

# Chromium's own profile goes into the output directory too, so nothing is left in $HOME.
raw="$out/report-raw.png"
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$PWD/$out/chromium-profile" \
    --window-size="$width,$height" --screenshot="$PWD/$raw" \
    "file://$PWD/$out/report.html" 2>/dev/null
if [ ! -s "$raw" ]; then
    echo "report-screenshot: chromium wrote no screenshot to $raw" >&2
    exit 1
fi

mkdir -p "$(dirname "$png")"
if command -v pngquant >/dev/null; then
    # 64 colours are plenty for the report's flat colours and text; --strip drops the metadata.
    # (The page shows the run's wall time, so two runs seldom give the same bytes.)
    pngquant --force --strip --speed 1 64 --output "$png" -- "$raw"
else
    echo "report-screenshot: pngquant not found, keeping Chromium's PNG unoptimised" >&2
    cp "$raw" "$png"
fi
echo "wrote $png ($(wc -c <"$png") bytes, ${width}x${height})"
