#!/usr/bin/env bash
# Removes what deploy/install.sh placed, as listed in its manifest. Configs it generated under
# /etc/frontseat are kept unless --purge; configs that existed before the install are never
# removed (they are not in the manifest).
#
#   deploy/uninstall.sh [--prefix DIR] [--destdir DIR] [--purge] [--no-systemctl]
#
#   --prefix DIR    the prefix given to install.sh (default /usr/local)
#   --destdir DIR   the staging directory given to install.sh: no systemctl, no userdel
#   --purge         also remove the generated configs, and the frontseat user
#   --no-systemctl  do not stop/disable the units or remove the user
# The environment variables DESTDIR and PREFIX do the same as the options.
set -euo pipefail

destdir="${DESTDIR:-}"
prefix="${PREFIX:-/usr/local}"
purge=0
system_actions=1

die() { echo "uninstall.sh: $*" >&2; exit 2; }

while [ $# -gt 0 ]; do
  case "$1" in
    --prefix) [ $# -ge 2 ] || die "--prefix needs a directory"; prefix="$2"; shift 2 ;;
    --destdir) [ $# -ge 2 ] || die "--destdir needs a directory"; destdir="$2"; shift 2 ;;
    --purge) purge=1; shift ;;
    --no-systemctl) system_actions=0; shift ;;
    -h|--help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument: $1 (see --help)" ;;
  esac
done

if [ -n "$destdir" ]; then
  system_actions=0
  [ -d "$destdir" ] || die "no such directory: $destdir"
  destdir="$(cd "$destdir" && pwd)"
  [ "$destdir" != "/" ] || destdir=""
fi
if [ "$system_actions" = 1 ] && [ "$(id -u)" != 0 ]; then
  die "uninstalling from the system needs root (or use --destdir DIR / --no-systemctl)"
fi

manifest="$prefix/share/frontseat/install-manifest"
[ -f "$destdir$manifest" ] || die "no install manifest at $destdir$manifest: nothing installed with this prefix"

# Refuse anything but absolute paths without `..`: the manifest decides what gets deleted.
safe() { case "$1" in /*) case "$1" in *..*) return 1 ;; esac; return 0 ;; *) return 1 ;; esac; }

if [ "$system_actions" = 1 ]; then
  while IFS= read -r line; do
    case "$line" in
      "file /etc/systemd/system/"*.service)
        unit="$(basename "${line#file }")"
        systemctl disable --now "$unit" 2>/dev/null || true ;;
    esac
  done < "$destdir$manifest"
fi

removed_dirs=()
kept=()
while IFS= read -r line; do
  kind="${line%% *}"
  path="${line#* }"
  safe "$path" || { echo "  skipped unsafe manifest entry: $line" >&2; continue; }
  case "$kind" in
    file) ;;
    config) if [ "$purge" != 1 ]; then echo "  kept $path (--purge removes it)"; kept+=("$line"); continue; fi ;;
    *) echo "  skipped unknown manifest entry: $line" >&2; continue ;;
  esac
  if [ -e "$destdir$path" ] || [ -L "$destdir$path" ]; then
    rm -f "$destdir$path"
    echo "  removed $path"
  fi
  removed_dirs+=("$(dirname "$path")")
done < "$destdir$manifest"

# The kept configs stay on record, for a later --purge or reinstall.
rm -f "$destdir$manifest"
removed_dirs+=("$(dirname "$manifest")")
if [ "${#kept[@]}" -gt 0 ]; then
  mkdir -p "$destdir$(dirname "$manifest")"
  printf '%s\n' "${kept[@]}" > "$destdir$manifest"
fi

# Our own directories, once empty (rmdir refuses non-empty ones, so a kept config keeps
# /etc/frontseat). A staged tree is ours entirely: its empty parents go too.
for dir in "$prefix/share/doc/frontseat/examples" "$prefix/share/doc/frontseat" \
    "$prefix/share/frontseat" /etc/frontseat; do
  rmdir "$destdir$dir" 2>/dev/null || true
done
if [ -n "$destdir" ]; then
  for dir in "${removed_dirs[@]}"; do
    while [ "$dir" != "/" ]; do
      if [ -d "$destdir$dir" ]; then rmdir "$destdir$dir" 2>/dev/null || break; fi
      dir="$(dirname "$dir")"
    done
  done
fi

if [ "$system_actions" = 1 ]; then
  systemctl daemon-reload
  if [ "$purge" = 1 ] && id frontseat >/dev/null 2>&1; then
    userdel frontseat && echo "  removed user frontseat"
  fi
fi
echo "done."
