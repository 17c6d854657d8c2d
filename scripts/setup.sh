#!/usr/bin/env bash
# Installs the Debian packages Strata needs and fetches the bundled sample scan.
# Idempotent: quiet when everything is already there. Works as root or through sudo.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake ninja-build g++ pkg-config
  libmeshoptimizer-dev libzstd-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev
  libepoxy-dev libegl-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev libglm-dev
  libopenexr-dev openexr libstb-dev xvfb
  python3  # the CLI tests read PNG pixels with it (tests/support/png_pixels.py)
  liblua5.4-dev ffmpeg libedit-dev tmux libimgui-dev xdotool
  libopenscenegraph-dev  # only for the cull benchmark (tests/bench/bench_cull.cpp), its peer
  clang libclang-rt-14-dev  # the fuzz build (scripts/fuzz.sh): clang++ and libFuzzer
)

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@";
  else echo "setup: need root (or sudo) to run: $*" >&2; exit 1; fi
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  as_root apt-get update -qq
  as_root apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# The sample: the Stanford bunny as shipped in CGAL's demo data (Debian's libcgal-demo). Only the .deb is
# downloaded and one file taken out of it, so CGAL and Boost are not installed. Not committed: it is
# Stanford's scan, fetched here under its own terms.
sample=data/bunny.off
if [ ! -s "$sample" ]; then
  echo "setup: fetching the sample scan (Stanford bunny, from Debian's libcgal-demo)"
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  (cd "$tmp" && apt-get download libcgal-demo >/dev/null 2>&1) || {
    as_root apt-get update -qq && (cd "$tmp" && apt-get download libcgal-demo >/dev/null); }
  dpkg-deb -x "$tmp"/libcgal-demo_*.deb "$tmp/deb"
  tar -xzf "$tmp/deb/usr/share/doc/libcgal-dev/data.tar.gz" -C "$tmp" data/meshes/bunny00.off
  mkdir -p data
  mv "$tmp/data/meshes/bunny00.off" "$sample.tmp" && mv "$sample.tmp" "$sample"
fi

# The sample terrain: a real DEM, NCL's trinidad.nc as shipped in Debian's libncarg-data (3 arc-second
# elevations in feet over 37-38°N, 104-106°W: the San Luis Valley and the Sangre de Cristo range), read
# by tests/support/dem_grid.h. Only the .deb is downloaded and that one file taken out of its data
# archive, so the package is not installed. Not committed: the package's copyright file
# (usr/share/doc/libncarg-data/copyright) puts all of it under "Files: *": Copyright 2013 University
# Corporation for Atmospheric Research, License BSD-4-clause (NCL's redistribution terms).
dem=data/trinidad.nc
if [ ! -s "$dem" ]; then
  echo "setup: fetching the sample terrain (trinidad.nc, from Debian's libncarg-data)"
  dem_tmp=$(mktemp -d)
  trap 'rm -rf "${tmp:-}" "$dem_tmp"' EXIT
  (cd "$dem_tmp" && apt-get download libncarg-data >/dev/null 2>&1) || {
    as_root apt-get update -qq && (cd "$dem_tmp" && apt-get download libncarg-data >/dev/null); }
  dpkg-deb --fsys-tarfile "$dem_tmp"/libncarg-data_*.deb |
    tar -x -C "$dem_tmp" ./usr/share/ncarg/data/cdf/trinidad.nc
  mkdir -p data
  mv "$dem_tmp/usr/share/ncarg/data/cdf/trinidad.nc" "$dem.tmp" && mv "$dem.tmp" "$dem"
fi
