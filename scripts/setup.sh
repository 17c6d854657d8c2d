#!/usr/bin/env bash
# Installs the Debian packages Strata needs and fetches the bundled sample scan.
# Idempotent: quiet when everything is already there. Works as root or through sudo.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  cmake ninja-build g++ pkg-config
  libmeshoptimizer-dev libzstd-dev libcli11-dev nlohmann-json3-dev
  libgdal-dev gdal-bin libproj-dev  # elevation rasters for terrain; the tests compare with gdalinfo, gdallocationinfo and PROJ
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

# Takes a file out of a Debian package without installing it: downloads the .deb into the scratch
# folder (removed on exit) and unpacks MEMBER (a path in its data archive) there; prints where it lies.
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
deb_member() {  # PACKAGE MEMBER
  local dir="$scratch/$1"
  mkdir -p "$dir"
  compgen -G "$dir/$1_*.deb" >/dev/null || (cd "$dir" && apt-get download "$1" >/dev/null 2>&1) || {
    as_root apt-get update -qq && (cd "$dir" && apt-get download "$1" >/dev/null); }
  dpkg-deb --fsys-tarfile "$dir/$1"_*.deb | tar -x -C "$dir" "./$2"
  echo "$dir/$2"
}

# Moves a fetched file into data/ in one step, so that a half-written file is never taken for the data.
install_data() {  # FROM TO
  mkdir -p data
  mv "$1" "$2.tmp" && mv "$2.tmp" "$2"
}

# The sample: the Stanford bunny as shipped in CGAL's demo data (Debian's libcgal-demo). Only the .deb is
# downloaded and one file taken out of it, so CGAL and Boost are not installed. Not committed: it is
# Stanford's scan, fetched here under its own terms.
sample=data/bunny.off
if [ ! -s "$sample" ]; then
  echo "setup: fetching the sample scan (Stanford bunny, from Debian's libcgal-demo)"
  meshes=$(deb_member libcgal-demo usr/share/doc/libcgal-dev/data.tar.gz)
  tar -xzf "$meshes" -C "$(dirname "$meshes")" data/meshes/bunny00.off
  install_data "$(dirname "$meshes")/data/meshes/bunny00.off" "$sample"
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
  install_data "$(deb_member libncarg-data usr/share/ncarg/data/cdf/trinidad.nc)" "$dem"
fi

# A real DEM with real imagery of the same ground, for terrain tests: Olinda and Recife (Brazil), as
# shipped in Debian's r-cran-stars: a 111 x 111 Float32 DEM at 90 m (UTM 25S, SRTM-like) and a
# Landsat-7 ETM+ scene of the same 10 km square at 28.5 m (six bands; true colour is 3, 2, 1). Only the
# .deb is downloaded and the two files taken out, so R is not installed. Not committed: the package's
# copyright file (usr/share/doc/r-cran-stars/copyright) puts them under the Apache License 2.0.
olinda_dem=data/olinda_dem.tif olinda_image=data/olinda_l7.tif
if [ ! -s "$olinda_dem" ] || [ ! -s "$olinda_image" ]; then
  echo "setup: fetching a DEM and imagery of Olinda (from Debian's r-cran-stars)"
  install_data "$(deb_member r-cran-stars usr/lib/R/site-library/stars/tif/olinda_dem_utm25s.tif)" "$olinda_dem"
  install_data "$(deb_member r-cran-stars usr/lib/R/site-library/stars/tif/L7_ETMs.tif)" "$olinda_image"
fi
