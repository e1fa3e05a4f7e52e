#!/bin/busybox sh
# The virtual bench guest's init (busybox): virtio + 9p, the host root over 9p, chroot, run the
# script named by vb_script= with vb_args=, write its exit status to the file named by vb_rc=.
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc; mount -t sysfs sys /sys; mount -t devtmpfs dev /dev
for m in virtio_ring virtio virtio_pci_modern_dev virtio_pci_legacy_dev virtio_pci netfs fscache 9pnet 9pnet_virtio 9p; do
  insmod /mods/$m.ko || echo "vbench-init: insmod $m failed"
done
if ! mount -t 9p -o trans=virtio,version=9p2000.L,msize=262144 hostroot /mnt; then
  echo "vbench-init: 9p mount failed"; poweroff -f
fi
mount -t proc proc /mnt/proc; mount -t sysfs sys /mnt/sys; mount -t devtmpfs dev /mnt/dev
mkdir -p /mnt/dev/pts /mnt/dev/shm; mount -t devpts pts /mnt/dev/pts; mount -t tmpfs shm /mnt/dev/shm
mount -t tmpfs run /mnt/run
mount -t configfs none /mnt/sys/kernel/config 2>/dev/null
S=$(sed -n 's/.*vb_script=\([^ ]*\).*/\1/p' /proc/cmdline)
RC=$(sed -n 's/.*vb_rc=\([^ ]*\).*/\1/p' /proc/cmdline)
echo "vbench-init: up at $(cut -d' ' -f1 /proc/uptime) s, running $S"
chroot /mnt /bin/bash "$S"
rc=$?
echo "$rc" > "/mnt$RC"
echo "vbench-init: guest script rc=$rc at $(cut -d' ' -f1 /proc/uptime) s"
sync; poweroff -f
