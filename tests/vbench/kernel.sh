#!/usr/bin/env bash
# Prepares the virtual bench's kernel side in the cache directory $VB (idempotent, cached):
# the kernel the archive has now (linux-image-amd64's dependency), its headers, kbuild and source
# fetched with `apt-get download` and unpacked with dpkg -x; gpio-sim.ko built out of tree from
# the source's gpio-sim.c + irq_sim.c against the matching headers; a busybox initramfs that mounts
# the host root over 9p and runs the guest script. Exits 77 (skip) when QEMU, busybox or the kernel
# packages cannot be had; any other failure is an error.
set -euo pipefail
VB=${1:?cache directory}
HERE=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$VB"
cd "$VB"
say() { echo "vbench: $*"; }
skip() { echo "vbench: SKIP: $*"; exit 77; }

need=()
command -v qemu-system-x86_64 >/dev/null || need+=(qemu-system-x86)
[ -x /bin/busybox ] || need+=(busybox-static)
command -v cpio >/dev/null || need+=(cpio)
dpkg-query -W -f='${Status}' libelf1 2>/dev/null | grep -q "ok installed" || need+=(libelf1)
command -v bc >/dev/null || need+=(bc)
if [ ${#need[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    skip "needs root to apt-get install ${need[*]} (run: apt-get install --no-upgrade ${need[*]})"
  fi
  say "installing ${need[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends --no-upgrade "${need[@]}" \
    || { apt-get update -qq || true
         apt-get -o DPkg::Lock::Timeout=900 install -y -qq --no-install-recommends --no-upgrade "${need[@]}"; } \
    || skip "cannot install ${need[*]}"
fi

# The kernel the archive has now: the ABI linux-image-amd64 depends on, its version for the source.
KVER=$(apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/.*Depends: linux-image-\([0-9].*\)$/\1/p' | head -1)
[ -n "$KVER" ] || { apt-get update -qq 2>/dev/null || true
  KVER=$(apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/.*Depends: linux-image-\([0-9].*\)$/\1/p' | head -1); }
[ -n "$KVER" ] || skip "apt-cache knows no linux-image-amd64 (no Debian archive?)"
KPKGVER=$(apt-cache show "linux-image-$KVER" | sed -n 's/^Version: //p' | head -1)
KSRC=${KVER%%-*}; KSRC=${KSRC%.*}                 # 6.1
K=$VB/k/$KVER
say "kernel $KVER ($KPKGVER)"
echo "$KVER" > "$VB/kver"
mkdir -p "$K/debs" "$K/root" "$K/src" "$K/mod"
if [ ! -f "$K/root/boot/vmlinuz-$KVER" ] || [ ! -f "$K/mod/gpio-sim.ko" ]; then
  cd "$K/debs"
  if ! ls "linux-image-${KVER}_"*.deb "linux-source-${KSRC}_"*.deb >/dev/null 2>&1; then
    say "apt-get download of linux-image-$KVER, headers, kbuild, source $KPKGVER"
    apt-get download "linux-image-$KVER=$KPKGVER" "linux-headers-$KVER=$KPKGVER" \
      "linux-headers-${KVER%-*}-common=$KPKGVER" "linux-kbuild-$KSRC=$KPKGVER" \
      "linux-source-$KSRC=$KPKGVER" >/dev/null || skip "apt-get download of the kernel packages failed"
  fi
  cd "$K"
  for d in debs/linux-headers-*.deb debs/linux-kbuild-*.deb debs/linux-image-*.deb; do dpkg -x "$d" root; done
  KDIR=$K/root/usr/src/linux-headers-$KVER
  # Unpacked (not installed) headers include the -common tree by its absolute /usr/src path.
  sed -i "s#^include /usr/src/#include $K/root/usr/src/#" "$KDIR/Makefile"
  S=src/linux-source-$KSRC
  dpkg-deb --fsys-tarfile debs/linux-source-"${KSRC}"_*.deb | tar -xO "./usr/src/linux-source-$KSRC.tar.xz" \
    | tar -xJ -C src "linux-source-$KSRC/drivers/gpio/gpio-sim.c" "linux-source-$KSRC/drivers/gpio/gpiolib.h" \
      "linux-source-$KSRC/kernel/irq/irq_sim.c"
  cp "$S/drivers/gpio/gpio-sim.c" mod/gpio-sim-core.c
  cp "$S/drivers/gpio/gpiolib.h" mod/gpiolib.h
  cp "$S/kernel/irq/irq_sim.c" mod/irq_sim.c
  # irq_to_desc() is not exported to modules; generic_handle_irq() (exported) reaches the same
  # handle_simple_irq for this descriptor.
  sed -i 's/handle_simple_irq(irq_to_desc(irqnum));/generic_handle_irq(irqnum);/' mod/irq_sim.c
  grep -q 'generic_handle_irq(irqnum)' mod/irq_sim.c
  printf 'obj-m := gpio-sim.o\ngpio-sim-y := gpio-sim-core.o irq_sim.o\n' > mod/Kbuild
  say "building gpio-sim.ko"
  make -s -C "$KDIR" M="$K/mod" modules 2>&1 | grep -v 'Skipping BTF' || true
  test -f mod/gpio-sim.ko
  rm -rf src  # only the three files were needed
fi

# The initramfs: virtio + 9p modules, mount the host root, chroot, run the script named on the
# kernel command line (vb_script=), write its exit status to vb_rc=, power off.
MODDIR=$K/root/lib/modules/$KVER/kernel
I=$VB/initramfs
if [ ! -f "$K/initramfs.cpio.gz" ]; then
  rm -rf "$I"; mkdir -p "$I"/{bin,dev,proc,sys,mnt,mods}
  cp /bin/busybox "$I/bin/busybox"
  for m in drivers/virtio/virtio_ring drivers/virtio/virtio drivers/virtio/virtio_pci_modern_dev \
           drivers/virtio/virtio_pci_legacy_dev drivers/virtio/virtio_pci fs/netfs/netfs \
           fs/fscache/fscache net/9p/9pnet net/9p/9pnet_virtio fs/9p/9p; do
    cp "$MODDIR/$m.ko" "$I/mods/"
  done
  cp "$HERE/init.sh" "$I/init"
  chmod +x "$I/init"
  (cd "$I" && find . | cpio -o -H newc --quiet | gzip -1 > "$K/initramfs.cpio.gz")
  rm -rf "$I"
fi
say "ready: $K"
