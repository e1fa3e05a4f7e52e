#!/usr/bin/env bash
# The Debian package, as a station PC would get it: `cpack -G DEB` in the build tree makes
# brakefit_<version>_amd64.deb; lintian finds nothing at warning level; the man pages render
# without warnings; and installed with dpkg into a throwaway root (an overlay of this system, so
# the dependencies shlibdeps named are checked against real installed packages and the maintainer
# scripts run), `brakefit --version`, `brakefitd --check` and a fit with the installed model run from
# it; purge removes it again.
#
# usage: test_deb.sh BUILD_DIR SOURCE_DIR VERSION     (exit 77: skipped, the reason printed)
set -euo pipefail
build=$(cd "$1" && pwd) src=$(cd "$2" && pwd) version=$3
deb="$build/brakefit_${version}_amd64.deb"
fail() { echo "FAIL: $*" >&2; exit 1; }

if [ -z "${BRAKEFIT_IN_NS:-}" ]; then
  rm -f "$deb"
  (cd "$build" && cpack -G DEB) >"$build/cpack.log" 2>&1 || { cat "$build/cpack.log"; fail "cpack -G DEB"; }
  [ -f "$deb" ] || fail "cpack made no $deb: $(ls "$build"/*.deb 2>/dev/null)"
  echo "built $(basename "$deb") ($(stat -c %s "$deb") bytes)"

  # Control: dependencies from shlibdeps, the config a conffile, the maintainer scripts.
  depends=$(dpkg-deb -f "$deb" Depends)
  echo "Depends: $depends"
  for lib in libc6 libstdc++6 libsqlite3-0 libmodbus5 libgpiod2 libsystemd0 libspdlog; do
    [[ "$depends" == *"$lib"* ]] || fail "Depends lacks $lib"
  done
  ctl=$(mktemp -d)
  trap 'rm -rf "$ctl"' EXIT
  dpkg-deb -e "$deb" "$ctl"
  [ "$(cat "$ctl/conffiles")" = /etc/brakefit/brakefitd.toml ] || fail "conffiles: $(cat "$ctl/conffiles")"
  for s in postinst prerm postrm; do [ -x "$ctl/$s" ] || fail "no executable $s"; done
  # The postinst creates nothing by hand: systemd-tmpfiles and DynamicUser= do.
  if grep -nE '^\s*[^#]*\b(mkdir|useradd|adduser|chown|install -d)\b' "$ctl/postinst"; then
    fail "postinst creates by hand what tmpfiles / DynamicUser do"
  fi
  files=$(dpkg-deb -c "$deb" | awk '{print $6}')
  for f in ./usr/bin/brakefit ./usr/sbin/brakefitd ./lib/systemd/system/brakefitd.service \
      ./lib/udev/rules.d/60-brakefit.rules ./usr/lib/tmpfiles.d/brakefit.conf \
      ./etc/brakefit/brakefitd.toml ./usr/share/brakefit/models/default.json \
      ./usr/bin/brakefit-sync ./usr/share/man/man1/brakefit-sync.1.gz \
      ./usr/share/man/man1/brakefit.1.gz ./usr/share/man/man8/brakefitd.8.gz \
      ./usr/share/doc/brakefit/copyright ./usr/share/doc/brakefit/changelog.gz; do
    grep -qxF "$f" <<<"$files" || fail "the package lacks $f"
  done

  command -v lintian >/dev/null || fail "lintian is not installed (scripts/test installs it)"
  if ! lintian --fail-on error,warning --tag-display-limit 0 "$deb" >"$build/lintian.log" 2>&1; then
    cat "$build/lintian.log"
    fail "lintian reports errors or warnings (above)"
  fi
  echo "lintian: clean at warning level"

  for page in "$build/man/brakefit.1.gz" "$build/man/brakefit-sync.1.gz" \
      "$build/man/brakefitd.8.gz"; do
    warn=$(LC_ALL=C.UTF-8 MANROFFSEQ='' MANWIDTH=80 man --warnings -l "$page" 2>&1 >/dev/null || true)
    [ -z "$warn" ] || fail "$(basename "$page"): $warn"
    # Every subcommand of the program is in its page.
    if [[ $page == *brakefit.1.gz ]]; then
      for sub in $("$build/cli/brakefit" --help | sed -n '/^Subcommands:/,$p' | awk 'NR>1{print $1}'); do
        zcat "$page" | grep -q "^\.SS \"brakefit $sub " || fail "brakefit.1 has no section for $sub"
      done
    fi
  done

  # The throwaway root needs a private mount namespace (root, or a user namespace) and overlayfs.
  if [ "$(id -u)" -eq 0 ]; then ns=(unshare --mount); else ns=(unshare --mount --map-root-user); fi
  if ! "${ns[@]}" true 2>/dev/null; then
    echo "SKIP: the throwaway-root install needs a mount namespace ($(id -un) cannot unshare one)"
    exit 77
  fi
  work=$(mktemp -d)
  rc=0
  BRAKEFIT_IN_NS=$work "${ns[@]}" "$0" "$@" || rc=$?
  rmdir "$work"  # the mounts on it went with the namespace
  exit $rc
fi

# --- inside a private mount namespace: an overlay of / on a tmpfs ------------------------------
work=$BRAKEFIT_IN_NS
mount -t tmpfs -o size=512m tmpfs "$work"
mkdir "$work/upper" "$work/work" "$work/root"
if ! mount -t overlay overlay -o "lowerdir=/,upperdir=$work/upper,workdir=$work/work" "$work/root" 2>"$work/err"; then
  echo "SKIP: the throwaway-root install needs overlayfs: $(cat "$work/err")"
  exit 77
fi
root=$work/root
mount -t proc proc "$root/proc"
rm -f "$root/var/lib/man-db/auto-update"  # no mandb run over the whole system in the trigger
# The host's own brakefit, if any, is not what is tested.
if dpkg-query --root="$root" -W brakefit >/dev/null 2>&1; then dpkg --root="$root" --purge brakefit >/dev/null; fi
cp "$deb" "$root/tmp/brakefit.deb"

chroot "$root" dpkg -i /tmp/brakefit.deb || fail "dpkg -i (dependencies as the package states them)"
status=$(chroot "$root" dpkg-query -W -f='${Status} ${Version}' brakefit)
[ "$status" = "install ok installed $version" ] || fail "dpkg status: $status"
chroot "$root" dpkg-query -W -f='${Conffiles}\n' brakefit | grep -q "/etc/brakefit/brakefitd.toml" \
  || fail "the config is not a registered conffile"

out=$(chroot "$root" brakefit --version)
echo "installed: $out"
[ "$out" = "brakefit $version" ] || fail "brakefit --version: $out"
out=$(chroot "$root" brakefitd --version)
[ "$out" = "brakefitd $version" ] || fail "brakefitd --version: $out"
out=$(chroot "$root" brakefitd --check)
echo "installed: $out"
[[ "$out" == "/etc/brakefit/brakefitd.toml: ok (model /usr/share/brakefit/models/default.json, sha256:"* ]] \
  || fail "brakefitd --check: $out"
# brakefit finds the installed model by itself: the source tree's is hidden, as on a station PC.
rm -rf "$root$src/data/models"
checksum=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["checksum"])' \
  "$root/usr/share/brakefit/models/default.json")
fit=$(env -u BRAKEFIT_MODEL chroot "$root" sh -c \
  'cd /tmp && brakefit synth --slip-max 0.27 --out c.csv && brakefit fit --json --method som c.csv')
[[ "$fit" == *"\"model_hash\":\"$checksum\""* ]] || fail "brakefit fit with the installed model: $fit"
echo "installed: brakefit fit --method som uses /usr/share/brakefit/models/default.json ($checksum)"
# The man pages are where man looks.
chroot "$root" man -w brakefit brakefit-sync brakefitd >/dev/null ||
  fail "man -w brakefit brakefit-sync brakefitd"
# The unit as installed verifies, its Documentation= man page included.
out=$(chroot "$root" systemd-analyze verify /lib/systemd/system/brakefitd.service 2>&1) \
  || fail "systemd-analyze verify of the installed unit: $out"
# The postinst ran systemd-tmpfiles: the state directory exists, mode 0750.
[ "$(stat -c %a "$root/var/lib/brakefit")" = 750 ] || fail "/var/lib/brakefit not created by the postinst"

chroot "$root" dpkg --purge brakefit || fail "dpkg --purge"
for f in /usr/bin/brakefit /usr/sbin/brakefitd /etc/brakefit/brakefitd.toml /lib/systemd/system/brakefitd.service; do
  [ ! -e "$root$f" ] || fail "$f left after purge"
done
echo "OK: built, lintian clean, installed into a throwaway root, ran, purged"
