#!/usr/bin/env bash
# Open MPI for `mpiexec -n N pvbatch` on the device machine, beyond ../shared/tools/pv-runtime's pack (which holds
# pvbatch and the MPI libraries it links, but not mpiexec, Open MPI's components -- loaded at run time, so ldd misses
# them -- nor its help texts): Debian's openmpi-bin, openmpi-common, libopenmpi3 and libpmix2 with every library they
# load (libc, libstdc++, libgcc and the GPU driver's left to the host), under mpi/ with their /usr paths.
# usage (here): pack_mpi_extras.sh OUT.tar.xz [PVRT_PARTS_DIR] ; with the runtime's parts, the libraries they hold
# already are left out. There, paraview_gpu_env.sh unpacks .devcarry/mpi-extras.tar.xz and points Open MPI at it
# (OPAL_PREFIX: Debian's Open MPI finds its components relative to its prefix).
set -euo pipefail
out=$(readlink -f "$1")
work=$(mktemp -d)
mkdir -p "$work/mpi/lib"
for p in openmpi-bin openmpi-common libopenmpi3 libpmix2; do dpkg -L "$p"; done | sort -u |
  grep -vE '^/usr/share/(doc|man|lintian)|/include/|\.a$|/pkgconfig/|java|\.mod$|mpif|fortran' |
  while read -r f; do if [ -f "$f" ] || [ -L "$f" ]; then echo "$f"; fi; done > "$work/files"
tar -cf - -T "$work/files" 2>/dev/null | tar -xf - -C "$work/mpi"
packed=$work/packed
touch "$packed"
if [ -n "${2:-}" ]; then cat "$2"/pvrt.tar.xz.part-* | xz -dc | tar -t | sed 's|.*/||' | sort -u > "$packed"; fi
hostlibs='/(libc\.so|libm\.so|libstdc\+\+|libgcc_s|ld-linux|libpthread|libdl\.so|librt\.so|libresolv|libcuda\.so|libnvidia)'
{ find "$work/mpi" -type f \( -name '*.so*' -o -path '*/bin/*' \) -print0 | xargs -0 -n1 ldd 2>/dev/null || true; } |
  awk '/=>/ && $3 ~ /^\// {print $3}' | sort -u | grep -vE "$hostlibs" | while read -r l; do
    r=$(readlink -f "$l")
    if [ -e "$work/mpi$r" ]; then continue; fi   # one of the packages' own
    if grep -qxF "$(basename "$r")" "$packed" && grep -qxF "$(basename "$l")" "$packed"; then continue; fi
    cp -a "$r" "$work/mpi/lib/"
    so=$(objdump -p "$r" | awk '/SONAME/ {print $2}')
    if [ -n "$so" ] && [ "$so" != "$(basename "$r")" ]; then ln -sf "$(basename "$r")" "$work/mpi/lib/$so"; fi
  done
tar -cf - -C "$work" mpi | xz -T2 -6 > "$out"
rm -rf "$work"
ls -la "$out"
