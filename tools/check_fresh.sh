#!/usr/bin/env bash
# The fresh-machine check: run the README's two quick-start commands, exactly as written,
# in a minimal Debian 12 root that has nothing but what Debian installs by default
# (`mmdebstrap --variant=apt`: essential packages plus apt). CI runs on a machine
# that developers worked on, where packages installed by hand hide a missing install step; this
# check cannot be fooled that way. It is not part of the test suite (it downloads and
# installs about 1 GB of packages and builds from scratch: 20-30 minutes on 2 cores).
#
#   tools/check_fresh.sh [--keep] [--root DIR]
#
# Needs root (chroot, bind mounts) and Debian's package mirror. Prints one line per
# command with its exit status and wall time, and exits non-zero if either failed. Logs
# go to DIR/log/{bootstrap,render,test}.log (DIR defaults to a fresh /tmp/pt-fresh.XXXX).
set -euo pipefail

keep=0
root=""
while [ $# -gt 0 ]; do
  case "$1" in
    --keep) keep=1 ;;
    --root) root=$2; shift ;;
    *) echo "usage: $0 [--keep] [--root DIR]" >&2; exit 2 ;;
  esac
  shift
done

[ "$(id -u)" -eq 0 ] || { echo "check_fresh: needs root (chroot and bind mounts)" >&2; exit 2; }
checkout=$(cd "$(dirname "$0")/.." && pwd)
shared=$(cd "$checkout/.." && pwd)/shared
[ -d "$shared" ] || echo "check_fresh: $shared is absent; tests that need it will skip" >&2

if ! command -v mmdebstrap >/dev/null; then
  echo "check_fresh: installing mmdebstrap" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends mmdebstrap >/dev/null
fi

[ -n "$root" ] || root=$(mktemp -d /tmp/pt-fresh.XXXX)
mkdir -p "$root"
logs=$root.log
mkdir -p "$logs"

mounted=()
cleanup() {
  for ((i=${#mounted[@]}-1; i>=0; i--)); do umount -l "${mounted[$i]}" 2>/dev/null || true; done
  if [ "$keep" -eq 0 ]; then rm -rf --one-file-system "$root"; fi
}
trap cleanup EXIT

t0=$(date +%s)
# The same Debian 12 suites as a freshly installed machine uses.
mmdebstrap --variant=apt --quiet bookworm "$root/sys-root" \
  "deb http://deb.debian.org/debian bookworm main" \
  "deb http://deb.debian.org/debian bookworm-updates main" \
  "deb http://deb.debian.org/debian-security bookworm-security main" \
  >"$logs/bootstrap.log" 2>&1 || { echo "check_fresh: mmdebstrap failed, see $logs/bootstrap.log" >&2; exit 1; }
sysroot=$root/sys-root
echo "bootstrap: minimal Debian 12 root in $(( $(date +%s) - t0 )) s ($(chroot "$sysroot" dpkg-query -W | wc -l) packages)"

# The checkout as git tracks it (no build trees, no local files), and shared/ beside it.
mkdir -p "$sysroot/work/main" "$sysroot/work/shared"
(cd "$checkout" && git ls-files -z --cached --others --exclude-standard | tar --null -T - -cf -) |
  tar -C "$sysroot/work/main" -xf -
cp -a "$shared/." "$sysroot/work/shared/" 2>/dev/null || true
cp /etc/resolv.conf "$sysroot/etc/resolv.conf"

for m in proc sys dev dev/pts; do
  mount --bind "/$m" "$sysroot/$m"
  mounted+=("$sysroot/$m")
done

status=0
for cmd in "./quickstart.sh render" "./quickstart.sh test"; do
  name=${cmd#./quickstart.sh }
  s=$(date +%s)
  set +e
  chroot "$sysroot" /usr/bin/env -i HOME=/root TERM=dumb LANG=C.UTF-8 \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    /bin/bash -c "cd /work/main && $cmd" >"$logs/$name.log" 2>&1
  rc=$?
  set -e
  tail_line=$(grep -E 'tests passed|rendered|Error|error:' "$logs/$name.log" | tail -n 1)
  echo "$cmd: exit $rc in $(( $(date +%s) - s )) s -- ${tail_line}"
  [ $rc -eq 0 ] || status=1
done
echo "logs: $logs"
exit $status
