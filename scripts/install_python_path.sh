#!/usr/bin/env bash
# Makes `import plumage` work in Debian's /usr/bin/python3 without an install step: writes a
# one-line path file, plumage.pth, into that interpreter's first site-packages folder
# (/usr/local/lib/python3.X/dist-packages on Debian: the folder for software not from Debian
# packages, so dpkg's /usr/lib/python3/dist-packages stays untouched) or, where that folder is not
# writable, into the user's site-packages. The line is the build's python folder; Python adds it
# to sys.path at start-up (the `site` module). The last checkout built is the one imported, as
# with `pip install -e`. A plumage.pth this script did not write (no marker line) is left alone
# and reported; nothing is ever deleted. Usage: install_python_path.sh BUILD_DIR
set -euo pipefail
build_dir=$(cd "$1" && pwd)
python=/usr/bin/python3
module_dir=$build_dir/python
marker="# written by Plumage's scripts/install_python_path.sh: the build's python folder"
[[ -x $python && -d $module_dir/plumage ]] || exit 0

write_pth() {  # DIR: 0 written or already current, 1 not writable, 2 someone else's file
  local dir=$1 file=$1/plumage.pth
  if [[ -f $file ]] && ! head -n 1 "$file" | grep -qxF "$marker"; then
    echo "plumage: $file exists and was not written by Plumage; left as it is" >&2
    return 2
  fi
  if [[ -f $file && $(tail -n 1 "$file") == "$module_dir" ]]; then return 0; fi
  mkdir -p "$dir" 2>/dev/null && [[ -w $dir ]] || return 1
  local tmp
  tmp=$(mktemp "$dir/.plumage.pth.XXXXXX") || return 1
  printf '%s\n%s\n' "$marker" "$module_dir" >"$tmp"
  chmod 644 "$tmp"
  mv -f "$tmp" "$file"  # atomic: a concurrent interpreter sees the old file or the new one
  echo "plumage: $python imports plumage from $module_dir (through $file)" >&2
}

# PLUMAGE_SITE_DIR and PLUMAGE_USER_SITE_DIR replace the two folders (the tests use them).
site_dir=${PLUMAGE_SITE_DIR:-$("$python" -c 'import site; print(site.getsitepackages()[0])')}
status=0
write_pth "$site_dir" || status=$?
if ((status == 1)); then
  write_pth "${PLUMAGE_USER_SITE_DIR:-$("$python" -m site --user-site)}" || true
fi
